"""Episodes: named scenarios (initial state and epoch) and the Mars approach's truth trajectory."""
