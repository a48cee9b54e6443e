"""The binauloc component (being written)."""
