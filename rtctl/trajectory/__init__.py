"""Joint-space trajectories: quintic (min-jerk) segments within velocity/acceleration limits.

Plan with :func:`point_to_point`, :func:`through_waypoints` (stopping at or passing through
the waypoints) and :func:`retarget` (replace a running trajectory without a jump in position,
velocity or acceleration); sample every tick with :meth:`JointTrajectory.sample`, which
writes into preallocated arrays and allocates nothing.
"""
from rtctl.trajectory.piecewise import JointTrajectory
from rtctl.trajectory.planning import JointLimits, hold, point_to_point, retarget, through_waypoints

__all__ = ["JointTrajectory", "JointLimits", "hold", "point_to_point", "through_waypoints", "retarget"]
