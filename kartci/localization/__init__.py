"""Lidar localization against a point-cloud map: deskewing, registration (small_gicp), and a
planar EKF fusing registration with wheel odometry and the gyroscope."""
