"""The episodic store port (:mod:`.base`) and its adapters (:mod:`.sqlite`, :mod:`.postgres`)."""
