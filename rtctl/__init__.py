"""rtctl: a real-time control runtime for robot joints."""
