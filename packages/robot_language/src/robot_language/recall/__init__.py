"""Questions about the past, read into the episodic tool call that answers them.

"what did you see 30 seconds ago", "when did you last see the mug", "where did you see the
scissors", "what happened while I was away / in the last 10 minutes", "where were you at
3 pm". The server resolves every time: the brain only passes relative strings (``-45s``) and
the clock text as said (``3pm``), never an absolute time it computed. A question about the past
never moves the robot. The entry module: its users import these names from here.
"""

from robot_language.recall.follow_up import follow_up_recall, looks_like_recall
from robot_language.recall.forms import default_recall, read_recall
from robot_language.recall.question import LAST_SEEN, POSE_AT, WHAT_HAPPENED, Recall

__all__ = [
    "LAST_SEEN",
    "POSE_AT",
    "WHAT_HAPPENED",
    "Recall",
    "default_recall",
    "follow_up_recall",
    "looks_like_recall",
    "read_recall",
]
