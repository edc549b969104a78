"""Obstacle detection from the lidar: ground and map removal, clustering, boxes with heading,
tracking across scans, static vs dynamic (source document 000, Sec. 5.2 / Fig. 6.4)."""
