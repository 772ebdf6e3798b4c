"""Which parts of a flash problem run as Dr.Jit kernels, and their sizes: :class:`KernelOptions`.

The sample estimator's work has two implementations of each step: a Dr.Jit kernel (the default:
both cores, or the GPU) and a numpy path, which is the reference the tests compare the kernel
with. One frozen :class:`KernelOptions` says which runs; a :class:`~labcut.orientation.problem.FlashProblem`
holds the options it was built with (``build_problem(..., kernels=)``), and its
:class:`~labcut.orientation.scoring.Scorer` and energy map read them from there, so a test or a
benchmark hands in another object instead of switching module state.

Every option changes how long an answer takes, never what it is beyond float32 rounding: each
kernel is tested against its numpy path (``tests/test_triple_batches.py``,
``tests/test_pair_sums.py``, ``tests/test_sparse_map.py``), and the defaults' answers are held to
the last bit by ``tests/test_golden_answers.py``. The cost constants (``map_min_terms``,
``map_min_normals``, ``tile_call_terms``) choose among the energy map's paths; ``benchmarks/recommend_switches.py``
measures the whole call with each switch off, and docs/performance.md records the figures.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..errors import ParameterError


@dataclass(frozen=True)
class KernelOptions:
    """Which flash-problem steps run as Dr.Jit kernels (module docstring).

    The switches, each with a numpy reference path:

    - ``triples``: the (point, light, view) terms of every pose at once, per chunk of
      ``dense_chunk`` (pair, light) cells, in float32 (numpy: float64 passes per pose).
    - ``lit_cells``: without occlusion rays, which lights reach each pair's point, tested and
      compacted on the device (needs ``triples``; off: the host's (points x lights) tables).
    - ``pair_sums``: the per-pair sums of the lobe terms (the error bars' bootstrap), a thread per
      (point, view) pair over its triples in order, for problems of at most
      ``pair_sums_max_triples`` triples (the kernel reads a device copy of them, 16 bytes each).
    - ``grid_keys``: the binning's stereographic grid keys from that device copy (needs
      ``pair_sums``).
    - ``bins``: the binning's sums as 64-bit fixed-point integers on the device (needs the device
      grid keys).
    - ``energy_map``: an energy map of at least ``map_min_normals`` normals, or of at least
      ``map_min_terms`` (normal, bin) terms within reach, in one kernel (float32 terms, float64 sums).

    ``tile_call_terms``: the cost of one numpy (normals x bins) block call, in lobe terms, with
    which the map's numpy path chooses between one block over a union of tiles and one per tile.
    ``map_kernel_rtol``: the map kernel's cull, the share of a lower bound of the best energy
    below which its dropped terms stay (its float32 terms are good to about 1e-6; the numpy
    paths cull at :data:`~labcut.orientation.scoring.SPARSE_RTOL`).
    """

    triples: bool = True
    lit_cells: bool = True
    pair_sums: bool = True
    grid_keys: bool = True
    bins: bool = True
    energy_map: bool = True
    dense_chunk: int = 4_000_000
    pair_sums_max_triples: int = 1 << 23
    map_min_terms: int = 1 << 20
    map_min_normals: int = 8
    tile_call_terms: int = 7000
    map_kernel_rtol: float = 1e-6

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.type in (bool, "bool"):
                if not isinstance(value, bool):
                    raise ParameterError(f"KernelOptions.{f.name} must be True or False, got {value!r}")
            elif f.type in (float, "float"):
                if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < 1.0:
                    raise ParameterError(f"KernelOptions.{f.name} must lie in (0, 1), got {value!r}")
            elif isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ParameterError(f"KernelOptions.{f.name} must be a whole number >= 1, got {value!r}")

    @classmethod
    def reference(cls) -> KernelOptions:
        """Every step on its numpy reference path (the kernels' tests compare with this)."""
        return cls(triples=False, lit_cells=False, pair_sums=False, grid_keys=False, bins=False, energy_map=False)

    @property
    def lit_cells_on_device(self) -> bool:
        """Whether the lit cells are found on the device (they need the triple kernel)."""
        return self.triples and self.lit_cells

    def pair_kernel_takes(self, n_triples: int) -> bool:
        """Whether the pair-sum kernel (and so the problem's device copy of its triples) serves a
        problem of ``n_triples`` triples."""
        return self.pair_sums and 0 < n_triples <= self.pair_sums_max_triples

    def device_keys_apply(self, n_triples: int, n_keys: int) -> bool:
        """Whether the binning takes its grid keys from the problem's device copy of the triples:
        where the pair-sum kernel makes that copy anyway and the keys fit an int32."""
        return self.grid_keys and self.pair_kernel_takes(n_triples) and n_keys < 2**31


#: the options every problem is built with unless told otherwise
DEFAULT_KERNELS = KernelOptions()
