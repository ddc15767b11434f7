"""Reading documents: located JSON, the schemas, the robot folder."""
