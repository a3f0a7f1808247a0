"""services/speech."""
