"""The event-sink port (where task events go) and its adapters."""
