"""ROS 2 as a front door of a running robot (`motivml run --ros2`): see node.py.

Imported only when asked for; rclpy is the optional extra `motivml[ros2]`.
"""
