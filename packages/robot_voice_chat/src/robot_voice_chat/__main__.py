"""`python -m robot_voice_chat` = the `robot-voice-chat` console script."""

from robot_voice_chat.main import main

if __name__ == "__main__":
    main()
