"""exodigit_nodes: thin rclpy nodes around exodigit_model (INTERFACES.md)."""
