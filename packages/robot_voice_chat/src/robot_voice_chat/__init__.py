"""The mission brain: voice/chat app with an agentic mission executor."""
