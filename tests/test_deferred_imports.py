"""trimesh's optional libraries are deferred to first use (labcut.deferred_imports), and
everything trimesh does with them gives the same answer as with a plain import.

Each check runs in a fresh interpreter: the deferral acts on a process's first ``import trimesh``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from labcut import deferred_imports

HEAVY = list(deferred_imports.DEFERRED)


def _run(code: str, eager: bool = False) -> dict:
    env = {**os.environ, "LABCUT_EAGER_IMPORTS": "1" if eager else "0"}
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env, timeout=240)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


LOADED = f"[m for m in {HEAVY!r} if m in sys.modules]"


def test_import_trimesh_after_labcut_leaves_the_libraries_unloaded():
    out = _run(f"""
        import json, sys
        import labcut, trimesh
        from labcut import deferred_imports as d
        after_import = {LOADED}
        mesh = labcut.load_mesh({str(deferred_imports.__file__).replace('labcut/deferred_imports.py', 'meshes/oval-16x12-low.ply')!r})
        print(json.dumps({{"after_import": after_import, "pending": d.pending(), "after_load": {LOADED},
                          "convex": bool(mesh.is_convex)}}))
    """)
    assert out["after_import"] == []
    assert set(out["pending"]) == set(HEAVY)
    assert "scipy.spatial" not in out["after_load"] and "networkx" not in out["after_load"]  # a convex cabochon needs neither
    assert out["convex"] is True


def test_eager_switch_and_an_earlier_trimesh_import_change_nothing():
    code = f"""
        import json, sys
        FIRST
        import labcut, trimesh
        print(json.dumps({{"loaded": {LOADED}, "real": type(trimesh.convex.ConvexHull).__name__}}))
    """
    eager = _run(code.replace("FIRST", ""), eager=True)
    before = _run(code.replace("FIRST", "import trimesh"))
    for out in (eager, before):
        assert set(out["loaded"]) >= {"scipy.spatial", "networkx"}
        assert out["real"] == "type"  # scipy's class itself, not a stand-in


# the same computations with the libraries deferred and imported plainly: every stand-in is used
SAME = """
    import json, sys
    import numpy as np
    import labcut, trimesh
    box = trimesh.creation.box(extents=(2.0, 3.0, 4.0))
    sphere = trimesh.creation.icosphere(subdivisions=2)
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0]], dtype=float)
    hull_flat = trimesh.convex.convex_hull(np.vstack([flat, [[0.5, 0.5, 1e-12]]]))  # Qhull fails, retried joggled
    shaded = trimesh.graph.smooth_shade(sphere, angle=0.5)
    obb = trimesh.bounds.oriented_bounds(box)
    center, radius = trimesh.nsphere.minimum_nsphere(sphere)
    graph = box.vertex_adjacency_graph  # networkx
    tree = sphere.kdtree  # scipy.spatial.cKDTree
    dist, idx = tree.query([[0.0, 0.0, 2.0]])
    out = {
        "hull_volume": float(sphere.convex_hull.volume), "hull_flat_faces": int(len(hull_flat.faces)),
        "shaded_vertices": int(len(shaded.vertices)), "obb_extents": sorted(float(x) for x in obb[1]),
        "nsphere_radius": float(radius), "graph_edges": int(graph.number_of_edges()), "kd": [float(dist[0]), int(idx[0])],
        "facets": int(len(box.facets)), "components": int(len(trimesh.graph.connected_components(box.face_adjacency))),
        "real": {
            "ConvexHull": trimesh.convex.ConvexHull is __import__("scipy.spatial").spatial.ConvexHull,
            "QhullError": trimesh.convex.QhullError is __import__("scipy.spatial").spatial.QhullError,
            "csgraph": trimesh.graph.csgraph is sys.modules["scipy.sparse.csgraph"],
            "nx": trimesh.graph.nx is sys.modules["networkx"],
            "cKDTree": trimesh.base.cKDTree is sys.modules["scipy.spatial"].cKDTree,
            "spatial": trimesh.nsphere.spatial is sys.modules["scipy.spatial"],
            "annotation": __import__("inspect").unwrap(trimesh.Trimesh.kdtree.fget).__annotations__.get("return")
                          is sys.modules["scipy.spatial"].cKDTree,
        },
        "stubs_left": [n for n, m in sys.modules.items() if type(m).__name__ == "_StubModule"],
    }
    print(json.dumps(out))
"""


def test_deferred_names_resolve_to_the_real_objects_with_the_same_results():
    lazy, eager = _run(SAME), _run(SAME, eager=True)
    for key in ("hull_flat_faces", "shaded_vertices", "graph_edges", "facets", "components"):
        assert lazy[key] == eager[key], key
    for key in ("hull_volume", "nsphere_radius"):
        assert lazy[key] == pytest.approx(eager[key], rel=1e-12), key
    assert lazy["obb_extents"] == pytest.approx(eager["obb_extents"], rel=1e-9)
    assert lazy["kd"] == pytest.approx(eager["kd"])
    assert lazy["real"] == {k: True for k in lazy["real"]}  # trimesh's names are scipy's and networkx's own after first use
    assert lazy["stubs_left"] == [] and eager["stubs_left"] == []


def test_a_later_import_gets_the_real_library():
    out = _run("""
        import json, sys
        import labcut, trimesh
        import scipy.spatial, networkx
        from scipy.sparse import csgraph
        print(json.dumps({"spatial": type(scipy.spatial).__name__, "hull": type(scipy.spatial.ConvexHull).__name__,
                          "nx": hasattr(networkx, "__version__"), "csgraph": type(csgraph).__name__,
                          "file": bool(getattr(scipy.spatial, "__file__", None))}))
    """)
    assert out == {"spatial": "module", "hull": "type", "nx": True, "csgraph": "module", "file": True}


def test_exception_names_are_classes_until_resolved(monkeypatch):
    import threading

    stub = deferred_imports._StubModule("scipy.fake_for_test")
    monkeypatch.setitem(deferred_imports._state, "window", threading.get_ident())  # as while trimesh imports
    in_trimesh: dict = {"__name__": "trimesh.fake_module", "stub": stub}  # code of a trimesh module asks
    exec("err = stub.QhullError; again = stub.QhullError; tree = stub.cKDTree", in_trimesh)
    err = in_trimesh["err"]
    assert isinstance(err, type) and issubclass(err, Exception) and in_trimesh["again"] is err
    assert isinstance(in_trimesh["tree"], deferred_imports._Deferred)
    with pytest.raises(AttributeError):  # dunders are not deferred (the import system probes them)
        exec("stub.__wrapped__", in_trimesh)
    with pytest.raises(ImportError):  # anyone else asks: the real module, which this one is not
        stub.anything  # noqa: B018
    monkeypatch.setitem(deferred_imports._state, "window", None)
    with pytest.raises(ImportError):  # after the window, trimesh's own later use: the real module too
        exec("stub.anything", in_trimesh)


def test_isinstance_against_a_stand_in_checks_the_real_class():
    from scipy.spatial import cKDTree

    proxy = deferred_imports._Deferred("scipy.spatial", "cKDTree")
    tree = cKDTree([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert isinstance(tree, proxy) and not isinstance(object(), proxy)
    assert issubclass(cKDTree, proxy) and not issubclass(int, proxy)


def test_other_threads_mean_a_plain_import():
    out = _run(f"""
        import json, sys, threading
        stop = threading.Event()
        threading.Thread(target=stop.wait, daemon=True).start()
        import labcut, trimesh
        print(json.dumps({{"loaded": {LOADED}}}))
        stop.set()
    """)
    assert set(out["loaded"]) >= {"scipy.spatial", "networkx"}


def test_a_library_other_than_trimesh_gets_the_real_objects_even_while_trimesh_imports():
    """A library that trimesh's import chain brings in (here: code run when trimesh.graph is
    about to load, after trimesh.base took its stand-ins) imports the real scipy.spatial."""
    out = _run("""
        import importlib.abc, json, sys
        seen = {}
        class Hook(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                if name == "trimesh.graph" and not seen:
                    space = {"__name__": "some_library"}
                    exec("import scipy.spatial\\nfrom scipy.spatial import ConvexHull, QhullError", space)
                    seen["hull"] = type(space["ConvexHull"]).__name__
                    seen["error_module"] = space["QhullError"].__module__
                    seen["module_real"] = bool(getattr(sys.modules["scipy.spatial"], "__file__", None))
                return None
        sys.meta_path.insert(0, Hook())
        import labcut, trimesh
        seen["base_tree_real"] = trimesh.base.cKDTree is sys.modules["scipy.spatial"].cKDTree  # swapped at once
        print(json.dumps(seen))
    """)
    assert out == {"hull": "type", "error_module": "scipy.spatial._qhull", "module_real": True, "base_tree_real": True}
