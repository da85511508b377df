"""The GUI's widgets and the window with its parts (Qt; never imports rospy)."""
