"""The robot's keyless language layer: ``Understanding.understand(text, places)`` gives a
``Reading``: what to do, a question naming what is missing, or a refusal; never a guess."""
