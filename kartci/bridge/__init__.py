"""A ROS 2-compatible bridge over Zenoh: kartci speaks rmw_zenoh's wire conventions so that a
team's own stack (ROS 2 nodes with `RMW_IMPLEMENTATION=rmw_zenoh_cpp`, or any program that
follows the same conventions) drives a simulated robot closed loop, in lockstep with sim time."""
