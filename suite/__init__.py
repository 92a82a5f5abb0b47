"""The knot-placement benchmark suite (installed as ``metaknot.suite``): a fixed, versioned set
of diverse instances, each with a stable id, a family, a definition and its source, and points
generated deterministically from that definition.

    from metaknot.suite import instances, get_instance
    data = get_instance("dj_doppler+noise0.01s0").point_set()
"""

from .instances import FAMILIES, NOISE_LEVELS, Instance, base_instances, get_instance, instances

__all__ = ["FAMILIES", "NOISE_LEVELS", "Instance", "base_instances", "get_instance",
           "instances"]
