"""The RTI hot path without CasADi's function-call machinery: the compiled linearisation
called on numpy buffers, and HPIPM through its own C interface.

CasADi's `conic("hpipm")` rebuilds HPIPM's structures on every call (fresh workspaces, sparse
projections into stage blocks, DM conversions on both sides). Here every buffer is allocated
once; per QP the stage blocks are gathered from the linearisation's nonzeros with index arrays
worked out once from the sparsity, and HPIPM is called through `d_ocp_qp_set_all` and
`d_ocp_qp_ipm_solve` of the library CasADi ships (its headers are in the same wheel). The data
are what CasADi's interface hands HPIPM, operation for operation (the Hessian and gradient
halved, the dynamics' right-hand sides negated, infinite bounds clipped to +-1e8, the solution
added to zeros), so the iterates are bit-identical to `ca.conic`'s (tests/robots/gokart/mpcc)."""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

INF = 1e8  # CasADi's HPIPM interface replaces infinite bounds with this
SPEED = 1  # enum hpipm_mode: SPEED_ABS, SPEED, BALANCE, ROBUST


def _library(name: str) -> ctypes.CDLL:
    """One of the libraries in CasADi's wheel (the ones its HPIPM plugin loads)."""
    return ctypes.CDLL(str(Path(ca.__file__).parent / name), mode=ctypes.RTLD_GLOBAL)


@dataclass(frozen=True)
class Stages:
    """The OCP's stage sizes: N stages, nx states, nu inputs and ng path constraints each."""

    n: int
    nx: list[int]
    nu: list[int]
    ng: list[int]


def _ptrs(buf: np.ndarray, sizes: list[int]) -> ctypes.Array[ctypes.c_void_p]:
    """An array of pointers (double* or int*) into consecutive slices of `buf`."""
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(int) * buf.itemsize
    return (ctypes.c_void_p * len(sizes))(*(buf.ctypes.data + int(o) for o in offsets))


def _block_index(sp: ca.Sparsity, blocks: list[tuple[int, int, int, int]]) -> np.ndarray:
    """For each (row, col, rows, cols) block, column-major, the index of each entry in the
    matrix's nonzeros; -1 (the appended zero) where it is structurally zero."""
    index = np.full(sp.shape, -1, dtype=np.intp)
    rows, cols = sp.get_triplet()
    index[rows, cols] = np.arange(sp.nnz())
    parts = [index[r:r + nr, c:c + nc].ravel(order="F") for r, c, nr, nc in blocks]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp)


def _fn(lib: ctypes.CDLL, name: str, *args: object, res: object = None) -> Any:
    """`lib`'s function `name` with its C argument and result types."""
    f = getattr(lib, name)
    f.argtypes, f.restype = list(args), res
    return f


class _Hpipm:
    """The library's functions this module calls, with their C signatures."""

    def __init__(self) -> None:
        _library("libblasfeo.so")
        lib = _library("libhpipm.so")
        vp, i, ip, sz = ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.c_size_t
        self.dim_strsize = _fn(lib, "d_ocp_qp_dim_strsize", res=sz)
        self.dim_memsize = _fn(lib, "d_ocp_qp_dim_memsize", i, res=sz)
        self.dim_create = _fn(lib, "d_ocp_qp_dim_create", i, vp, vp)
        self.dim_set_all = _fn(lib, "d_ocp_qp_dim_set_all", ip, ip, ip, ip, ip, ip, vp)
        self.qp_strsize = _fn(lib, "d_ocp_qp_strsize", res=sz)
        self.qp_memsize = _fn(lib, "d_ocp_qp_memsize", vp, res=sz)
        self.qp_create = _fn(lib, "d_ocp_qp_create", vp, vp, vp)
        self.qp_set_all = _fn(lib, "d_ocp_qp_set_all", *([vp] * 27))
        self.sol_strsize = _fn(lib, "d_ocp_qp_sol_strsize", res=sz)
        self.sol_memsize = _fn(lib, "d_ocp_qp_sol_memsize", vp, res=sz)
        self.sol_create = _fn(lib, "d_ocp_qp_sol_create", vp, vp, vp)
        self.sol_get_all = _fn(lib, "d_ocp_qp_sol_get_all", *([vp] * 12))
        self.arg_strsize = _fn(lib, "d_ocp_qp_ipm_arg_strsize", res=sz)
        self.arg_memsize = _fn(lib, "d_ocp_qp_ipm_arg_memsize", vp, res=sz)
        self.arg_create = _fn(lib, "d_ocp_qp_ipm_arg_create", vp, vp, vp)
        self.arg_set_default = _fn(lib, "d_ocp_qp_ipm_arg_set_default", i, vp)
        dp = ctypes.POINTER(ctypes.c_double)
        self.arg_set_iter_max = _fn(lib, "d_ocp_qp_ipm_arg_set_iter_max", ip, vp)
        self.arg_set_tols = [_fn(lib, f"d_ocp_qp_ipm_arg_set_tol_{name}", dp, vp)
                             for name in ("stat", "eq", "ineq", "comp")]
        self.ws_strsize = _fn(lib, "d_ocp_qp_ipm_ws_strsize", res=sz)
        self.ws_memsize = _fn(lib, "d_ocp_qp_ipm_ws_memsize", vp, vp, res=sz)
        self.ws_create = _fn(lib, "d_ocp_qp_ipm_ws_create", vp, vp, vp, vp)
        self.solve = _fn(lib, "d_ocp_qp_ipm_solve", vp, vp, vp, vp)
        self.get_status = _fn(lib, "d_ocp_qp_ipm_get_status", vp, ip)
        self.get_iter = _fn(lib, "d_ocp_qp_ipm_get_iter", vp, ip)


_LIB: list[_Hpipm] = []


def _hpipm() -> _Hpipm:
    """The library, loaded on first use (a run without the RTI mode never loads it)."""
    if not _LIB:
        _LIB.append(_Hpipm())
    return _LIB[0]


class _Memory:
    """Buffers HPIPM's structures live in, kept alive as long as the QP."""

    def __init__(self) -> None:
        self.buffers: list[ctypes.Array[ctypes.c_char]] = []

    def __call__(self, size: int) -> ctypes.Array[ctypes.c_char]:
        buf = ctypes.create_string_buffer(max(int(size), 1))
        self.buffers.append(buf)
        return buf


def _ints(values: list[int]) -> ctypes.Array[ctypes.c_int]:
    return (ctypes.c_int * len(values))(*values)


class OcpQp:
    """An OCP-structured QP of fixed sizes and sparsity, solved by HPIPM in memory allocated
    once: min 1/2 dw' H dw + grad' dw  s.t.  lba <= J dw <= uba, lbx <= dw <= ubx, where the
    rows of J are per stage the dynamics (equalities, -I on x_{k+1}) and the path constraints,
    as `ocp.build` stacks them."""

    def __init__(self, st: Stages, h_sp: ca.Sparsity, a_sp: ca.Sparsity, iter_max: int,
                 tol: float) -> None:
        lib = _hpipm()
        n, nx, nu, ng = st.n, st.nx, st.nu, st.ng
        mem = self._mem = _Memory()
        self._dims = [_ints(v) for v in (nx, nu, nx, nu, ng, [0] * (n + 1))]
        self.dim = mem(lib.dim_strsize())
        lib.dim_create(n, self.dim, mem(lib.dim_memsize(n)))
        lib.dim_set_all(*self._dims, self.dim)
        self.qp = mem(lib.qp_strsize())
        lib.qp_create(self.dim, self.qp, mem(lib.qp_memsize(self.dim)))
        self.sol = mem(lib.sol_strsize())
        lib.sol_create(self.dim, self.sol, mem(lib.sol_memsize(self.dim)))
        self.arg = mem(lib.arg_strsize())
        lib.arg_create(self.dim, self.arg, mem(lib.arg_memsize(self.dim)))
        lib.arg_set_default(SPEED, self.arg)
        lib.arg_set_iter_max(ctypes.byref(ctypes.c_int(iter_max)), self.arg)
        for set_tol in lib.arg_set_tols:
            set_tol(ctypes.byref(ctypes.c_double(tol)), self.arg)
        self.ws = mem(lib.ws_strsize())
        lib.ws_create(self.dim, self.arg, self.ws, mem(lib.ws_memsize(self.dim, self.arg)))
        self._layout(st, h_sp, a_sp)
        self._buffers(st)

    def _layout(self, st: Stages, h_sp: ca.Sparsity, a_sp: ca.Sparsity) -> None:
        """Index arrays from the QP's sparsity to HPIPM's column-major stage blocks."""
        n, nx, nu, ng = st.n, st.nx, st.nu, st.ng
        col = np.concatenate([[0], np.cumsum([nx[k] + nu[k] for k in range(n + 1)])])
        row = np.concatenate([[0], np.cumsum([nx[k + 1] + ng[k] for k in range(n)])])
        a_blocks: dict[str, list[tuple[int, int, int, int]]] = {k: [] for k in "ABCDI"}
        for k in range(n + 1):
            r = row[k] if k < n else row[n]
            dyn = nx[k + 1] if k < n else 0
            if k < n:
                a_blocks["A"].append((r, col[k], dyn, nx[k]))
                a_blocks["B"].append((r, col[k] + nx[k], dyn, nu[k]))
                a_blocks["I"] += [(r + i, col[k + 1] + i, 1, 1) for i in range(dyn)]
            a_blocks["C"].append((r + dyn, col[k], ng[k], nx[k]))
            a_blocks["D"].append((r + dyn, col[k] + nx[k], ng[k], nu[k]))
        self._a_index = {key: _block_index(a_sp, b) for key, b in a_blocks.items()}
        c0 = col[:-1]
        self._h_index = {
            "Q": _block_index(h_sp, [(c, c, nx[k], nx[k]) for k, c in enumerate(c0)]),
            "S": _block_index(h_sp, [(c + nx[k], c, nu[k], nx[k]) for k, c in enumerate(c0)]),
            "R": _block_index(h_sp, [(c + nx[k], c + nx[k], nu[k], nu[k])
                                     for k, c in enumerate(c0)])}
        # the row of I (and of b) each entry of A and B is scaled with
        self._row_of = {
            "A": np.concatenate([np.tile(np.arange(nx[k + 1]), nx[k]) + sum(nx[1:k + 1])
                                 for k in range(n)]),
            "B": np.concatenate([np.tile(np.arange(nx[k + 1]), nu[k]) + sum(nx[1:k + 1])
                                 for k in range(n)])}
        self._dyn_rows = np.concatenate([np.arange(row[k], row[k] + nx[k + 1])
                                         for k in range(n)])
        path_start = [row[k] + nx[k + 1] for k in range(n)] + [row[n]]
        self._path_rows = np.concatenate([np.arange(path_start[k], path_start[k] + ng[k])
                                          for k in range(n + 1)])
        self._x_cols = np.concatenate([np.arange(col[k], col[k] + nx[k]) for k in range(n + 1)])
        self._u_cols = np.concatenate([np.arange(col[k] + nx[k], col[k + 1])
                                       for k in range(n + 1)])
        self.size = int(col[-1])

    def _buffers(self, st: Stages) -> None:
        """numpy buffers for every stage block, those filled alike in one array each (one
        numpy call fills them), and the pointer arrays HPIPM reads them by."""
        n, nx, nu, ng = st.n, st.nx, st.nu, st.ng
        nb = [a + b for a, b in zip(nx, nu, strict=True)]
        groups: dict[str, dict[str, list[int]]] = {
            "jac": {"A": [nx[k + 1] * nx[k] for k in range(n)],
                    "B": [nx[k + 1] * nu[k] for k in range(n)],
                    "C": [ng[k] * nx[k] for k in range(n + 1)],
                    "D": [ng[k] * nu[k] for k in range(n + 1)]},
            "hess": {"Q": [v * v for v in nx], "S": [nu[k] * nx[k] for k in range(n + 1)],
                     "R": [v * v for v in nu]},
            "grad": {"q": nx, "r": nu}, "lower": {"lbx": nx, "lbu": nu},
            "upper": {"ubx": nx, "ubu": nu}, "sol": {"x": nx, "u": nu},
            "b": {"b": nx[1:]}, "lg": {"lg": ng}, "ug": {"ug": ng},
            "duals": {"pi": nx[1:], "lam_lb": nb, "lam_ub": nb, "lam_lg": ng, "lam_ug": ng}}
        self.buf: dict[str, np.ndarray] = {}
        self._p = {}
        for group, parts in groups.items():
            whole = self.buf[group] = np.zeros(sum(sum(v) for v in parts.values()) + 1)
            offset = 0
            for key, sizes in parts.items():
                self._p[key] = _ptrs(whole[offset:], sizes)
                offset += sum(sizes)
        a, h = self._a_index, self._h_index
        self._jac_index = np.concatenate([a["A"], a["B"], a["C"], a["D"], [-1]])
        self._hess_index = np.concatenate([h["Q"], h["S"], h["R"], [-1]])
        self._var_index = np.concatenate([self._x_cols, self._u_cols])
        self._sizes = {"A": sum(groups["jac"]["A"]), "B": sum(groups["jac"]["B"])}
        # every variable is boxed: bound j of a stage is its variable j
        self._index = np.concatenate([np.arange(v) for v in nx + nu] + [[0]]).astype(np.intc)
        self._idxbx = _ptrs(self._index, nx)
        self._idxbu = _ptrs(self._index[sum(nx):], nu)
        self._none = (ctypes.c_void_p * (n + 1))()  # slacks: none

    def _fill(self, hess: np.ndarray, jac: np.ndarray, grad: np.ndarray, lba: np.ndarray,
              uba: np.ndarray, lbx: np.ndarray, ubx: np.ndarray) -> None:
        """The stage blocks from the QP, as CasADi's interface computes them. `take` wraps
        (-1 is the appended zero): with `out`, its default mode copies through a buffer."""
        b, var = self.buf, self._var_index
        np.take(jac, self._jac_index, out=b["jac"], mode="wrap")
        diag = jac[self._a_index["I"]]
        np.multiply(lba[self._dyn_rows], -1.0, out=b["b"][:-1])
        if not (diag == -1.0).all():  # else a scale of 1.0: the same bits
            scale = -1.0 / diag  # -1 / the coefficient of x_{k+1}
            na, nb = self._sizes["A"], self._sizes["B"]
            b["jac"][:na] *= scale[self._row_of["A"]]
            b["jac"][na:na + nb] *= scale[self._row_of["B"]]
            b["b"][:-1] *= scale
        np.take(hess, self._hess_index, out=b["hess"], mode="wrap")
        b["hess"] *= 0.5  # HPIPM's cost is 1/2 of CasADi's
        np.multiply(grad[var], 0.5, out=b["grad"][:-1])
        np.add(0.0, lbx[var], out=b["lower"][:-1])
        np.add(0.0, ubx[var], out=b["upper"][:-1])
        np.take(lba, self._path_rows, out=b["lg"][:-1], mode="wrap")
        np.take(uba, self._path_rows, out=b["ug"][:-1], mode="wrap")
        for key in ("lower", "lg"):
            np.maximum(b[key], -INF, out=b[key])
        for key in ("upper", "ug"):
            np.minimum(b[key], INF, out=b[key])

    def solve(self, hess: np.ndarray, jac: np.ndarray, grad: np.ndarray, lba: np.ndarray,
              uba: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
              out: np.ndarray) -> tuple[bool, int]:
        """The step into `out`, whether HPIPM solved it (status 0) and its iteration count.
        `hess` and `jac` are the nonzeros of H and J, each with one zero appended."""
        self._fill(hess, jac, grad, lba, uba, lbx, ubx)
        lib, p, none = _hpipm(), self._p, self._none
        lib.qp_set_all(p["A"], p["B"], p["b"], p["Q"], p["S"], p["R"], p["q"], p["r"],
                       self._idxbx, p["lbx"], p["ubx"], self._idxbu, p["lbu"], p["ubu"],
                       p["C"], p["D"], p["lg"], p["ug"], none, none, none, none,
                       none, None, none, none, self.qp)
        lib.solve(self.qp, self.sol, self.arg, self.ws)
        status, iters = ctypes.c_int(), ctypes.c_int()
        lib.get_status(self.ws, ctypes.byref(status))
        lib.get_iter(self.ws, ctypes.byref(iters))
        lib.sol_get_all(self.sol, p["u"], p["x"], none, none, p["pi"], p["lam_lb"],
                        p["lam_ub"], p["lam_lg"], p["lam_ug"], none, none)
        out[self._var_index] = self.buf["sol"][:-1]
        out += 0.0  # CasADi adds the solution to zeros: -0.0 becomes 0.0
        return status.value == 0, iters.value


class CompiledFunction:
    """A CasADi function generated as C and compiled (`cache.py`), called through its C entry
    point on numpy buffers allocated once: the same machine code `ca.external` runs, without
    the DM conversions. Outputs are the nonzeros of each output, each with one zero appended
    (the structural zeros `OcpQp`'s index arrays point at)."""

    def __init__(self, fn: ca.Function, library: Path) -> None:
        lib = ctypes.CDLL(str(library))
        name = fn.name()
        self._call = _fn(lib, name, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                         ctypes.c_void_p, ctypes.c_int, res=ctypes.c_int)
        self._lib = lib
        sizes = [fn.sz_arg(), fn.sz_res(), fn.sz_iw(), fn.sz_w()]
        self.inputs = [np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
        self.outputs = [np.zeros(fn.nnz_out(i) + 1) for i in range(fn.n_out())]
        self._arg = (ctypes.c_void_p * max(sizes[0], 1))(
            *[a.ctypes.data for a in self.inputs])
        self._res = (ctypes.c_void_p * max(sizes[1], 1))(
            *[r.ctypes.data for r in self.outputs])
        self._iw = np.zeros(max(sizes[2], 1), dtype=np.int64)
        self._w = np.zeros(max(sizes[3], 1))
        self._mem = _fn(lib, f"{name}_checkout", res=ctypes.c_int)()

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        """The outputs for these inputs (views of buffers the next call overwrites)."""
        for buf, value in zip(self.inputs, args, strict=True):
            buf[:] = value
        if self._call(self._arg, self._res, self._iw.ctypes.data, self._w.ctypes.data,
                      self._mem):
            raise FloatingPointError(f"{self._lib._name}: evaluation failed")
        return self.outputs
