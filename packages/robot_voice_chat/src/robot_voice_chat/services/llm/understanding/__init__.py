"""The embedded understanding layer (intents as data, semantic matching, live slots)."""
