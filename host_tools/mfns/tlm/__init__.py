"""Telemetry: the XTCE dictionary for Python, ROS 2 messages and the MCAP / rosbag2 export."""
