"""exodigit_nodes: thin rclpy nodes around exodigit_model (docs/spec/ros.md)."""
