"""The arm port (pick/place actions + what is held) and its adapters."""
