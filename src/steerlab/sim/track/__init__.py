"""The track world: a donkeycar on a procedural track in a hall, seen through its fisheye (`sim --world track`)."""
