"""Python client of the towed-decoy solver's host bridge."""
