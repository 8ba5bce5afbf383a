"""Solar-system data, ephemerides and time scales."""
