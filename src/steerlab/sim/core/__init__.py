"""What every world shares: the driving loop, its contracts, the vehicle, the parallel runner, the donkeycar part
as a pilot and the suites' common parts."""
