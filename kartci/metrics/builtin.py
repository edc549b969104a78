"""kartci's own kind-neutral metric sets, registered through entry points like any team's
(each robot kind's own sets live with it: `kartci.robots.<kind>.metrics`)."""

from __future__ import annotations

from kartci.core import MetricSet
from kartci.metrics.detection import DEFS as DETECTION_DEFS
from kartci.metrics.detection import DetectionMetricsParams, detection_metrics
from kartci.metrics.localization import DEFS as LOCALIZATION_DEFS
from kartci.metrics.localization import LocalizationMetricsParams, localization_metrics

LOCALIZATION = MetricSet(
    "localization", LOCALIZATION_DEFS, localization_metrics, LocalizationMetricsParams, (),
    "localization estimate vs ground truth: APE / RPE (evo's conventions), convergence from "
    "the initial guess, divergence events")
DETECTION = MetricSet(
    "detection", DETECTION_DEFS, detection_metrics, DetectionMetricsParams, (),
    "obstacle detections vs ground-truth boxes: recall within range, precision, position "
    "error, static/dynamic accuracy, latency")
