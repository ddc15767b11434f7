"""ROS 2 for a running robot: the bridge process that holds rclpy, and its `motivml` node.

`bridge.py` is the process (`python -m motivml.ros2`), `graph.py` its rclpy, `lifecycle.py`
the nodes of ros2_lifecycle plugins, `node.py` the `motivml` node; `door.py` is the run's
side of that node and imports no rclpy. rclpy is the optional extra `motivml[ros2]`.
"""
