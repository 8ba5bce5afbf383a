"""Episodes: named scenarios (initial state and epoch), the Mars approach harness, and the Monte Carlo
navigation harness."""
