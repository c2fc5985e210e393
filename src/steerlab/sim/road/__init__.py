"""The road world: a full-size car on procedural roads seen through a pinhole camera (`sim --world road`)."""
