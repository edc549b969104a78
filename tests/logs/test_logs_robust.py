"""Damaged and foreign logs: every reader path gives one line naming the file, or salvages what
is readable and says so; never a traceback or a bare library exception.

The fuzz tests feed truncated, byte-flipped and spliced copies of every shipped log (and of every
real recorded log in ../shared/fixtures, when present) through topics(), messages(), tables()
and extract(). Their inputs are fixed (derandomized, or a fixed seed per part of the long run),
so CI sees the same ones on every run. The long run (10,000+ inputs) is in the full tier:
`KARTCI_LONG=1 pytest -m long tests/logs/test_logs_robust.py`.
"""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rosbags.rosbag1 import Reader as Ros1Reader
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from kartci.errors import KartciError, LogError
from kartci.logs import (
    SalvagedLog,
    extract,
    header,
    messages,
    msg,
    open_log,
    tables,
    topics,
    typestore,
)
from kartci.logs.damage import describe

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios" / "logs").glob("*.mcap"))
FIXTURES = ROOT.parent / "shared" / "fixtures" / "bags"
POSE = "float32 x\nfloat32 y\nfloat32 theta\nfloat32 linear_velocity\nfloat32 angular_velocity\n"


# ------------------------------------------------------------------------------------- helpers


def _ros1_store(extra: dict[str, str]) -> Typestore:
    store = get_typestore(Stores.ROS1_NOETIC)
    for name, text in extra.items():
        store.register(get_types_from_msg(text, name))
    return store


def _turtle_bag(path: Path, n: int = 10) -> None:
    """A ROS 1 bag, as turtlesim records it: turtlesim/msg/Pose is defined only in the bag."""
    store = _ros1_store({"turtlesim/msg/Pose": POSE})
    with Ros1Writer(path) as w:
        conn = w.add_connection("/turtle1/pose", "turtlesim/msg/Pose", typestore=store)
        for k in range(n):
            pose = store.types["turtlesim/msg/Pose"](x=float(k), y=2.0, theta=0.5,
                                                     linear_velocity=1.0, angular_velocity=0.0)
            w.write(conn, 1_000_000_000 + k * 10_000_000,
                    store.serialize_ros1(pose, "turtlesim/msg/Pose"))


def _chunked_mcap(path: Path, n: int = 400, chunk_size: int = 2048) -> None:
    """A kartci-style run log (ROS 2, zstd, CRCs, summary) cut into many small chunks."""
    text, _ = typestore().generate_msgdef("sensor_msgs/msg/Range", ros_version=2)
    with path.open("wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        w.start(profile="ros2", library="test")
        sid = w.register_schema("sensor_msgs/msg/Range", "ros2msg", text.encode())
        cid = w.register_channel("/sonar", "cdr", sid)
        for k in range(n):
            m = msg("sensor_msgs/msg/Range", header=header(k * 1000, "sonar"), radiation_type=0,
                    field_of_view=0.5, range=float(k), min_range=0.0, max_range=9.0)
            w.add_message(cid, log_time=k * 1000, publish_time=k * 1000,
                          data=bytes(typestore().serialize_cdr(m, "sensor_msgs/msg/Range")))
        w.finish()  # type: ignore[no-untyped-call]


def _summary_start(data: bytes) -> int:
    return int(struct.unpack_from("<Q", data, len(data) - 37 + 9)[0])


def _one_line(err: BaseException, path: Path) -> str:
    text = str(err)
    assert "\n" not in text and text.startswith(f"{path}: "), text
    assert "Traceback" not in text and "AssertionError" not in text
    return text


@dataclass
class Read:
    """What a reader call gave, with the SalvagedLog notes it issued."""

    value: Any
    notes: list[str]


def _reading(call: Callable[[], Any]) -> Read:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = call()
    notes = [str(w.message) for w in caught if issubclass(w.category, SalvagedLog)]
    return Read(value, notes)


# ------------------------------------------------------------- the known failing cases (issue)


def test_damaged_mcap_summary_is_read_by_streaming(tmp_path: Path) -> None:
    """Case 1: a huge record length in the summary made rosbags raise OverflowError in topics(),
    messages() and extract(); the data section is intact, so everything is salvaged."""
    src = SHIPPED[0]
    good = bytearray(src.read_bytes())
    bad = tmp_path / "summary.mcap"
    good[_summary_start(bytes(good)) + 8] = 0xFF  # top byte of the first summary record's length
    bad.write_bytes(bytes(good))

    info = _reading(lambda: topics(bad))
    assert info.value == topics(src)
    assert len(info.notes) == 1
    assert info.notes[0].startswith(f"{bad}: a record claims an impossible length")
    assert "read by streaming without the index" in info.notes[0]
    got = _reading(lambda: [(t, ns) for t, ns, _ in messages(bad)])
    assert got.value == [(t, ns) for t, ns, _ in messages(src)]
    out = tmp_path / "out.mcap"
    n = _reading(lambda: extract(bad, [info.value[0].topic], out))
    assert n.value == info.value[0].count and n.notes
    assert [(t, ns) for t, ns, _ in messages(out)] == got.value


def test_corrupted_zstd_chunk_is_skipped(tmp_path: Path) -> None:
    """Case 2: a damaged zstd frame gave a bare ZstdError from extract(); now that chunk is
    skipped and every other chunk is copied, with a note saying so."""
    log = tmp_path / "run.mcap"
    _chunked_mcap(log)
    with log.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.chunk_indexes) > 5
    chunk = summary.chunk_indexes[2]
    data = bytearray(log.read_bytes())
    frame = chunk.chunk_start_offset + 1 + 8 + 8 + 8 + 8 + 4 + 4 + len("zstd") + 8
    data[frame: frame + 4] = b"\x00\x00\x00\x00"  # the zstd frame magic
    log.write_bytes(bytes(data))

    out = tmp_path / "sonar.mcap"
    n = _reading(lambda: extract(log, ["/sonar"], out))
    assert 300 < n.value < 400
    assert len(n.notes) == 1 and n.notes[0].startswith(f"{log}: a zstd-compressed chunk")
    assert "1 damaged chunk not fully read" in n.notes[0]
    ranges = [m.range for _, _, m in messages(out)]
    assert len(ranges) == n.value and len(set(ranges)) == n.value  # resumed without repeats
    assert ranges == sorted(ranges) and ranges[0] == 0.0 and ranges[-1] == 399.0


def test_extract_registers_types_defined_only_in_a_ros1_bag(tmp_path: Path) -> None:
    """Case 3: turtlesim/msg/Pose is in no ROS 2 type store (TypesysError before); extract
    writes it with the bag's own definition, and the copy reads back."""
    bag = tmp_path / "turtle.bag"
    _turtle_bag(bag)
    out = tmp_path / "pose.mcap"
    assert extract(bag, ["/turtle1/pose"], out) == 10
    got = list(messages(out))
    assert [m.__msgtype__ for _, _, m in got] == ["turtlesim/msg/Pose"] * 10
    assert [m.x for _, _, m in got] == pytest.approx([float(k) for k in range(10)])
    with out.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert [(s.name, s.encoding) for s in summary.schemas.values()] == [
        ("turtlesim/msg/Pose", "ros2msg")]


def test_extract_types_defined_only_in_a_rosbag2(bags: Path, tmp_path: Path) -> None:
    """The same for a real rosbag2 (sqlite3) whose test_msgs are in no type store."""
    out = tmp_path / "arrays.mcap"
    assert extract(bags / "rosbag2_cdr_test_db3", ["/test_topic"], out) == 3
    assert [m.__msgtype__ for _, _, m in messages(out)] == ["test_msgs/msg/BasicTypes"] * 3


def _old_layout_bag(path: Path) -> None:
    """A bag whose index data header carries one field more than rosbags expects: rosbags
    fails on it with a bare `AssertionError()`, which used to reach the user as
    `cannot read log (AssertionError: )`. Its chunks are intact."""
    _turtle_bag(path)
    data = bytearray(path.read_bytes())
    start = data.index(b"op=\x04") - 8  # header length, then the op field's length
    size = struct.unpack_from("<I", data, start)[0]
    extra = b"\x0a\x00\x00\x00writer=old"
    data[start + 4 + size: start + 4 + size] = extra
    struct.pack_into("<I", data, start, size + len(extra))
    at = data.index(b"index_pos=") + len(b"index_pos=")  # the index moved by len(extra)
    struct.pack_into("<Q", data, at, struct.unpack_from("<Q", data, at)[0] + len(extra))
    path.write_bytes(bytes(data))


def test_old_bag_layout_is_said_in_words_and_read(tmp_path: Path) -> None:
    """Case 4: the AssertionError becomes words that name the file, and the bag is read by
    walking its chunks instead of its index."""
    bag = tmp_path / "old.bag"
    _old_layout_bag(bag)
    with pytest.raises(AssertionError) as raised, Ros1Reader(bag):
        pass
    assert "index records are laid out in a way" in describe(raised.value)

    got = _reading(lambda: [m.x for _, _, m in messages(bag)])
    assert got.value == pytest.approx([float(k) for k in range(10)])
    assert len(got.notes) == 1
    assert got.notes[0].startswith(f"{bag}: its chunk index records are laid out in a way")
    assert "AssertionError" not in got.notes[0]


def test_old_bag_layout_without_chunks_is_one_clear_line(tmp_path: Path) -> None:
    """When nothing can be streamed either, the same words end in a LogError."""
    bag = tmp_path / "old.bag"
    _old_layout_bag(bag)
    data = bag.read_bytes()
    at = data.index(b"op=\x05")  # the first chunk: cut the file there
    bag.write_bytes(data[: at - 8])
    with pytest.raises(LogError) as raised:
        topics(bag)
    assert "AssertionError" not in _one_line(raised.value, bag)


def test_extract_refuses_to_replace_its_own_source(tmp_path: Path) -> None:
    """Case 5: `extract LOG -o LOG` used to replace LOG with the extract."""
    log = tmp_path / "run.mcap"
    shutil.copy(SHIPPED[0], log)
    before = log.read_bytes()
    for dst in (log, tmp_path / "." / "run.mcap", tmp_path / "link.mcap"):
        if dst.name == "link.mcap":
            os.link(log, dst)
        with pytest.raises(LogError, match="is the log being read") as raised:
            extract(log, ["/kart0/joy"], dst)
        _one_line(raised.value, dst)
    assert log.read_bytes() == before


def test_extract_refuses_an_output_in_the_source_folder(bags: Path, tmp_path: Path) -> None:
    folder = tmp_path / "talker"
    shutil.copytree(bags / "rosbag2_talker_mcap", folder)
    for dst in (folder, folder / "talker.mcap", folder / "topic.mcap"):
        with pytest.raises(LogError):
            extract(folder, ["/topic"], dst)
    assert sorted(p.name for p in folder.iterdir()) == ["metadata.yaml", "talker.mcap"]


def test_failed_extract_leaves_the_old_output_alone(tmp_path: Path) -> None:
    """A log that defines std_msgs/msg/String with an int fails part way through the copy (the
    ROS 2 String wants text): one line, no half-written file, the previous output untouched."""
    store = _ros1_store({})
    store2 = get_typestore(Stores.EMPTY)
    store2.register(get_types_from_msg("int32 data\n", "std_msgs/msg/String"))
    bag = tmp_path / "odd.bag"
    with Ros1Writer(bag) as w:
        ok = w.add_connection("/ok", "std_msgs/msg/Float32", typestore=store)
        odd = w.add_connection("/odd", "std_msgs/msg/String", typestore=store2)
        for k in range(5):
            w.write(ok, k, store.serialize_ros1(store.types["std_msgs/msg/Float32"](data=k),
                                                "std_msgs/msg/Float32"))
        w.write(odd, 10, store2.serialize_ros1(store2.types["std_msgs/msg/String"](data=3),
                                               "std_msgs/msg/String"))
    out = tmp_path / "out.mcap"
    out.write_bytes(b"an earlier extract")
    with pytest.raises(LogError, match=r"/odd \(std_msgs/msg/String\) cannot be written") as r:
        extract(bag, ["/ok", "/odd"], out)
    _one_line(r.value, bag)
    assert out.read_bytes() == b"an earlier extract"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["odd.bag", "out.mcap"]


# ------------------------------------------------------------------------- more damage, foreign


def test_truncated_real_ros1_bag_is_salvaged(bags: Path, tmp_path: Path) -> None:
    """A recording cut off part way (no index at all): the chunks before the cut are read."""
    cut = tmp_path / "cut.bag"
    data = (bags / "jackal_imu_odom.bag").read_bytes()
    cut.write_bytes(data[: len(data) * 6 // 10])
    got = _reading(lambda: tables(cut))
    odom = got.value["/jackal_velocity_controller/odom"]
    assert 1000 < len(odom) < 3060
    assert (odom["t"].diff().dropna() >= 0).all()
    assert len(got.notes) == 1 and got.notes[0].startswith(f"{cut}: ")


def test_unindexed_bag_is_read(tmp_path: Path) -> None:
    """`rosbag record` killed before it wrote the index leaves index_pos = 0."""
    bag = tmp_path / "killed.bag"
    _turtle_bag(bag)
    data = bytearray(bag.read_bytes())
    at = data.index(b"index_pos=") + len(b"index_pos=")
    struct.pack_into("<Q", data, at, 0)
    bag.write_bytes(bytes(data))
    got = _reading(lambda: topics(bag))
    assert [(i.topic, i.count) for i in got.value] == [("/turtle1/pose", 10)]
    assert "the bag has no index (the recording did not finish)" in got.notes[0]


def test_message_that_does_not_decode_is_skipped(tmp_path: Path) -> None:
    """A CDR failure loses one message, not the log; the note names topic, type and count."""
    text, _ = typestore().generate_msgdef("std_msgs/msg/String", ros_version=2)
    log = tmp_path / "strings.mcap"
    good = bytes(typestore().serialize_cdr(msg("std_msgs/msg/String", data="hi"),
                                           "std_msgs/msg/String"))
    with log.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        cid = w.register_channel("/s", "cdr", w.register_schema("std_msgs/msg/String",
                                                                 "ros2msg", text.encode()))
        for k, data in enumerate([good, good[:4] + b"\xff\xff\xff\x7f" + good[8:], good]):
            w.add_message(cid, log_time=k, publish_time=k, data=data)
        w.finish()  # type: ignore[no-untyped-call]
    got = _reading(lambda: [(ns, m.data) for _, ns, m in messages(log)])
    assert got.value == [(0, "hi"), (2, "hi")]
    assert got.notes == [f"{log}: skipped messages that do not decode: 1 on /s "
                         f"(std_msgs/msg/String: {got.notes[0].split('String: ', 1)[1]}"]


def test_foreign_mcap_profile_and_encodings(tmp_path: Path) -> None:
    """An MCAP not written by ROS 2 tools (no profile, a JSON topic beside a CDR one): rosbags
    refuses it; the CDR topic is read by streaming and the JSON topic is said to be left out."""
    text, _ = typestore().generate_msgdef("std_msgs/msg/String", ros_version=2)
    log = tmp_path / "foreign.mcap"
    with log.open("wb") as f:
        w = Writer(f)
        w.start(profile="")
        cdr = w.register_channel("/s", "cdr", w.register_schema("std_msgs/msg/String",
                                                                "ros2msg", text.encode()))
        js = w.register_channel("/j", "json", w.register_schema("J", "jsonschema", b"{}"))
        data = typestore().serialize_cdr(msg("std_msgs/msg/String", data="x"),
                                         "std_msgs/msg/String")
        w.add_message(cdr, log_time=1, publish_time=1, data=bytes(data))
        w.add_message(js, log_time=2, publish_time=2, data=b"{}")
        w.finish()  # type: ignore[no-untyped-call]
    got = _reading(lambda: [(t, m.data) for t, _, m in messages(log)])
    assert got.value == [("/s", "x")]
    assert "profile is not ros2" in got.notes[0] and "left out 1 topic" in got.notes[0]


def test_messages_of_a_topic_the_log_lacks(tmp_path: Path) -> None:
    """AnyReader reads every topic when given no connection; a missing topic gives nothing."""
    assert list(messages(SHIPPED[0], ["/nope"])) == []


def test_a_damaged_chunk_compression_name_is_not_quoted(tmp_path: Path) -> None:
    """Found by the long fuzz: a file cut inside a chunk whose compression name was damaged
    into bytes of the file (a newline among them) was named in the error, which then broke
    over two lines and showed the file's contents."""
    data = bytearray(SHIPPED[0].read_bytes())
    at = data.index(b"zstd", data.index(b"\x06"))  # the first chunk's compression name
    data[at:at + 4] = b"MC\nP"
    log = tmp_path / "cut.mcap"
    log.write_bytes(bytes(data[: at + 200]))
    with pytest.raises(KartciError) as err:  # the cut falls in the only chunk: nothing to read
        sum(1 for _ in messages(log))
    text = str(err.value)
    assert "\n" not in text and "MC" not in text.replace("MCAP", "") and text.startswith(
        f"{log}: "), text
    assert "(an unknown compression, " in text, text


def test_rosbag2_folder_whose_metadata_does_not_match_its_storage(bags: Path) -> None:
    """rosbags' reader reads no message of this real rosbag2 (its QoS in metadata.yaml and in
    the MCAP differ); kartci's MCAP reader matches the folder's topics to the file's channels
    by topic and type, so every message is read as it is, with no salvage note (the data are
    whole; only a QoS profile, which reading does not use, disagrees)."""
    got = _reading(lambda: [t for t, _, _ in messages(bags / "rosbag2_talker_mcap")])
    assert sorted(set(got.value)) == ["/rosout", "/topic"] and len(got.value) == 20
    assert got.notes == []


@pytest.mark.parametrize("content", [b"", b"hello, not a log\n", b"\x89MCAP0\r\n", b"#ROSBAG"])
@pytest.mark.parametrize("name", ["x.mcap", "x.bag", "x.db3"])
def test_not_a_log_is_one_line(tmp_path: Path, content: bytes, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(LogError) as raised:
        topics(path)
    _one_line(raised.value, path)


def test_open_log_notes(tmp_path: Path) -> None:
    """Callers that want to say so themselves read LogReader.notes instead of warnings."""
    bag = tmp_path / "old.bag"
    _old_layout_bag(bag)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(bag) as log:
            assert log.notes[0].startswith(f"{bag}: ")
    with open_log(SHIPPED[0]) as log:
        assert not log.salvaged and log.notes == []


# -------------------------------------------------------------------------------------- fuzzing


def _sources(with_fixtures: bool) -> list[Path]:
    found = list(SHIPPED)
    if with_fixtures and FIXTURES.is_dir():
        found += sorted(FIXTURES.iterdir())
    return found


def _files(source: Path) -> list[Path]:
    """The files of a log that damage can hit: the log itself, or each file of a folder."""
    return sorted(source.iterdir()) if source.is_dir() else [source]


@dataclass(frozen=True)
class Damage:
    """A recipe, in fractions of the file's length so that one recipe fits any file."""

    kind: str
    where: tuple[float, ...]

    def apply(self, data: bytes) -> bytes:
        n = max(len(data), 1)
        at = [min(int(f * n), n - 1) for f in self.where]
        if self.kind == "truncate":
            return data[: at[0]]
        if self.kind == "splice":  # a slice of the file copied over another place
            lo, hi = sorted(at[:2])
            return data[: at[2]] + data[lo:hi] + data[at[2] + (hi - lo):]
        out = bytearray(data)
        for k, pos in enumerate(at):
            if out:
                out[pos] ^= (1 << (k % 8)) | 0x01  # bit 0 and one more
        return bytes(out)


fractions = st.floats(0.0, 1.0, exclude_max=True, allow_nan=False)
damages = st.one_of(
    st.builds(Damage, st.just("truncate"), st.tuples(fractions)),
    st.builds(Damage, st.just("flip"), st.lists(fractions, min_size=1, max_size=8).map(tuple)),
    st.builds(Damage, st.just("splice"), st.tuples(fractions, fractions, fractions)),
    # the tail of a file holds its index or summary: aim there often
    st.builds(Damage, st.just("flip"), st.lists(st.floats(0.9, 1.0, exclude_max=True),
                                                 min_size=1, max_size=4).map(tuple)),
)


FUZZ = settings(derandomize=True, database=None, deadline=None, print_blob=False,
                suppress_health_check=list(HealthCheck))


@contextmanager
def _damaged_copy(source: Path, damage: Damage, pick: int) -> Iterator[Path]:
    """A copy of the log in a fresh folder with one of its files damaged (copied file by file:
    the fixtures are read-only, and so would the copy be)."""
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / source.name
        if source.is_dir():
            copy.mkdir()
            for f in _files(source):
                shutil.copyfile(f, copy / f.name)
        files = _files(source)
        original = files[pick % len(files)]
        target = copy / original.name if source.is_dir() else copy
        target.write_bytes(damage.apply(original.read_bytes()))
        yield copy


def _outcome(call: Callable[[], Any], *paths: Path) -> tuple[str, Any]:
    """'read', 'salvaged' or 'error'; any exception that is not a KartciError propagates and
    fails the test, as do notes or errors of more than one line or not naming the file."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = call()
        except KartciError as err:
            text = str(err)
            assert "\n" not in text and text.startswith(tuple(f"{p}: " for p in paths)), text
            return "error", None
    notes = [str(w.message) for w in caught if issubclass(w.category, SalvagedLog)]
    for note in notes:
        assert "\n" not in note and note.startswith(f"{paths[0]}: "), note
    return ("salvaged" if notes else "read"), value


CALLS = ("topics", "messages", "tables", "extract")


def _fuzz_one(source: Path, damage: Damage, pick: int,
              calls: tuple[str, ...] = CALLS) -> dict[str, str]:
    """Each of `calls` (`topics` always runs: it names the topic `extract` takes) on one damaged
    copy: the outcome of each."""
    with _damaged_copy(source, damage, pick) as log:
        out = log.parent / "extract.mcap"
        got, info = _outcome(lambda: topics(log), log)
        results = {"topics": got}
        if "messages" in calls:
            results["messages"] = _outcome(lambda: sum(1 for _ in messages(log)), log)[0]
        if "tables" in calls:
            results["tables"] = _outcome(lambda: tables(log), log)[0]
        if "extract" in calls:
            wanted = [info[0].topic] if info else ["/kart0/joy"]
            results["extract"] = _outcome(lambda: extract(log, wanted, out), log, out)[0]
        return results


@settings(FUZZ, max_examples=40)  # the long tier runs 10,000+
@given(st.sampled_from(SHIPPED), damages, st.integers(0, 7))
def test_fuzz_shipped_logs(source: Path, damage: Damage, pick: int) -> None:
    _fuzz_one(source, damage, pick)


@settings(FUZZ, max_examples=40)  # the long tier runs 10,000+
@given(st.integers(0, 63), damages, st.integers(0, 7))
def test_fuzz_real_recorded_logs(bags: Path, which: int, damage: Damage, pick: int) -> None:
    logs = sorted(bags.iterdir())
    _fuzz_one(logs[which % len(logs)], damage, pick)


@pytest.mark.long(reason="fuzzing with 10,000+ damaged logs")
@pytest.mark.parametrize("part", range(4))
def test_fuzz_long(part: int, capsys: pytest.CaptureFixture[str]) -> None:
    """10,000+ damaged copies of every shipped and (when present) real recorded log, in four
    parts (2,500+ each, each its own fixed seed) so that two workers share the run evenly.
    Each copy is opened (`topics`) and read by one more call the fuzzer picks: every call
    reads 2,500+ damaged logs in all, at under half the time of all four on each copy (CI
    gave this test 58 of its 90 worker-minutes with all four)."""
    sources = _sources(with_fixtures=True)
    seen: Counter[str] = Counter()

    @seed(part)
    @settings(FUZZ, derandomize=False, max_examples=2_550)
    @given(st.sampled_from(sources), damages, st.integers(0, 7), st.sampled_from(CALLS[1:]))
    def one(source: Path, damage: Damage, pick: int, call: str) -> None:
        seen["inputs"] += 1
        for name, got in _fuzz_one(source, damage, pick, ("topics", call)).items():
            seen[f"{name} {got}"] += 1

    one()
    with capsys.disabled():
        print(f"\nlong fuzz over {len(sources)} logs: {dict(sorted(seen.items()))}")
    assert seen["inputs"] >= 2_500
    assert all(sum(n for key, n in seen.items() if key.startswith(f"{call} ")) >= 600
               for call in CALLS[1:])
