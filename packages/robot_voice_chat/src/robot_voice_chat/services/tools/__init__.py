"""services/tools."""
