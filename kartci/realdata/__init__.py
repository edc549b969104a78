"""Logs from elsewhere (real robots, other simulators): import profiles, scoring, sim-vs-real
divergence, model calibration and open-loop sensor replay."""
