"""`python -m robot_voice_chat` = the `robot-voice-chat` console script."""

import sys

from robot_voice_chat.main import main

if __name__ == "__main__":
    sys.exit(main())
