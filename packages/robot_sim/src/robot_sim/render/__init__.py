"""The camera's view, rendered with MuJoCo: the office as primitives (scene.py), the offscreen
renderer (renderer.py) and the annotations read from its segmentation (annotate.py)."""
