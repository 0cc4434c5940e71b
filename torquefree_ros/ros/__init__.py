"""The ROS layer: the simulator node, its parameters and sample loop, the topic recorder and bag
player, QoS conversions and process handling. Imports rclpy; the core and the bag tools do not."""
