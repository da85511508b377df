"""GidaBot's touch-screen GUI: ``core`` (no Qt, no ROS), ``qt`` (widgets, no ROS), ``gui_node`` (the ROS node)."""
