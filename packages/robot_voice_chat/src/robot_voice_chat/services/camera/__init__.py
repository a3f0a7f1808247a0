"""services/camera: the latest camera frame (with overlays) for the operator's UI."""
