"""Recommend the lamella orientation of a cut: lighting and viewing models, flash metrics, optimisers."""
