"""services/emitter."""
