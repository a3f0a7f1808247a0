"""Test doubles of the brain (``robot_voice_chat``): its executor and whole app on fakes at every
port, a simulated office behind the fake tool backend, model stand-ins behind the fake model
APIs. Tests and benchmarks import them; the brain's product code never does, and nothing here
builds the executor itself (``robot_voice_chat.composition`` does). Needs the brain installed
(the workspace); the pytest plugin of this package never imports it."""
