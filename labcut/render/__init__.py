"""Rendering with Mitsuba 3: the ``labradorite`` BSDF plugin, scenes, and :func:`render`."""
