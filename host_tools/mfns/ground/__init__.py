"""Ground-side programs: the Yamcs ground system, the operator's view, the live Foxglove stream."""
