"""Test doubles of the vision node's outside world (``robot_mcp_perception``): a strict local
fake of the Gemini ``generateContent`` API (``fake_gemini``) that tests and benchmarks point the
real grounder at. No preset or deployment uses it: a keyless node runs the fake grounder
(``grounder=fake``, ``robot_mcp_perception.models.fakes``), never this server."""
