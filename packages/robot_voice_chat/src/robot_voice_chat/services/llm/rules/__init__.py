"""The rules planner, rules chat and template distiller: deterministic offline stand-ins for
the cloud models behind the same LLMProvider port (ARCHITECTURE §6). Nothing here is a model:
they understand a fixed set of commands over the live tool surface and say so."""
