"""The vision skill model and its validation (spec 000 §3, ARCHITECTURE §4.1, §6a).

Standard library only: the vision node and the MCP bridges validate skills with the same code
without pulling in ROS, OpenCV or model SDKs.
"""

from robot_skill_schema.skill import (
    GROUNDING_REQUIRED_MODES,
    MAX_OUTPUTS,
    MAX_RATE_HZ,
    MAX_SKILL_JSON_BYTES,
    MAX_TEXT_CHARS,
    OUTPUT_TYPES,
    RESERVED_OUTPUT_NAMES,
    SEGMENTING_MODES,
    SKILL_MODES,
    WATCHABLE_OUTPUT_TYPES,
    OutputType,
    Skill,
    SkillError,
    SkillMode,
    SkillOutput,
    WatchSpec,
    is_topic_token,
    parse_json_object,
)

__all__ = [
    "GROUNDING_REQUIRED_MODES",
    "MAX_OUTPUTS",
    "MAX_RATE_HZ",
    "MAX_SKILL_JSON_BYTES",
    "MAX_TEXT_CHARS",
    "OUTPUT_TYPES",
    "RESERVED_OUTPUT_NAMES",
    "SEGMENTING_MODES",
    "SKILL_MODES",
    "WATCHABLE_OUTPUT_TYPES",
    "OutputType",
    "Skill",
    "SkillError",
    "SkillMode",
    "SkillOutput",
    "WatchSpec",
    "is_topic_token",
    "parse_json_object",
]
