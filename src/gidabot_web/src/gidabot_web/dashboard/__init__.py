"""The staff dashboard every robot serves (docs/dashboard.md): the core (:mod:`.dashboard`, ROS-free),
its history (:mod:`.history`, SQLite), the web application (:mod:`.app`) and the node
(:mod:`.dashboard_node`)."""
