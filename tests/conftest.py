"""Shared test helpers: pytest reads this file first (fixtures used by several test files go here)."""
