"""Runtime: stereo capture, the live loop, replay, LCM terrain messages and the simulated
approach. Sits on top of :mod:`stereo_terrain.pipeline`; nothing below imports it."""
