"""Skill = the unit of configuration of the vision node. The model and its validation live in
the light ``robot_skill_schema`` package (ARCHITECTURE §6a) so skill_control validates skills
without this package's OpenCV / model dependencies; this module keeps the node's import path."""

from robot_skill_schema import (
    MAX_SKILL_JSON_BYTES,
    OUTPUT_TYPES,
    SKILL_MODES,
    Skill,
    SkillError,
    SkillOutput,
    WatchSpec,
    is_topic_token,
    parse_json_object,
)

__all__ = [
    "MAX_SKILL_JSON_BYTES",
    "OUTPUT_TYPES",
    "SKILL_MODES",
    "Skill",
    "SkillError",
    "SkillOutput",
    "WatchSpec",
    "is_topic_token",
    "parse_json_object",
]
