"""What the GUI decides and says: records, the visitor flow, texts, admin checks (imports neither Qt nor rospy)."""
