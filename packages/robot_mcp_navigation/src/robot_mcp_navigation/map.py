"""The map file (named locations, cruise speed, injected failures): its format lives in
``robot_site_map``, shared with robot-sim; navigation's modules import it from here."""

from robot_site_map import FailureSpec, MapError, NavMap, load_map, parse_map

__all__ = ["FailureSpec", "MapError", "NavMap", "load_map", "parse_map"]
