"""Second engines that cross-check ``twin.physics`` (MuJoCo, the simulator the paper's authors used)."""
