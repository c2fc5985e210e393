"""Closed-loop replay on recordings of real drives (`steerlab replay`): the road replay and the small cars'."""
