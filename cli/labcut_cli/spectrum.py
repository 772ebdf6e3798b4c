"""``labcut spectrum`` (placeholder removed below once written)."""
