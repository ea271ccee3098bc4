"""gel: Python access to geld, the gelsim job service, and to gelsim's files.

    import gel
    client = gel.connect("127.0.0.1:50051")          # token: $GELD_TOKEN_FILE or $GELD_TOKEN, as gelctl
    job_id = client.submit("quick", seeds=[1, 2], labels={"study": "demo"})
    for update in client.watch(job_id):                # plain dicts, ends when the job ends
        if update["type"] == "progress":
            print(update["k"], update["phi"], update["P"])
    curve = client.curve(job_id)                       # pandas.DataFrame, curve.csv's columns
    for job, curve in client.query_curves(labels={"study": "demo"}, where=["generator.seed>=2"]):
        print(job["id"], len(curve))                   # many jobs' curves: bond preset, labels, scene fields
    table = client.query_curves_frame(where=[("generator.lx", ">=", 30)])  # one DataFrame, job_id column
    config = gel.read_configuration("gel.json")        # numpy arrays: x, y, theta, bond_i, ...

Units are the engine's (docs/model.md): lengths in particle radii a, forces in F0, stresses in
F0/a^2, energies in F0 a, times in t0; curve columns carry them in their names ("P [F0/a^2]").

The package needs the stubs protoc generates from proto/gel/v1 (gel/v1/*_pb2.py). Installed,
they sit in this directory's v1/. In a source checkout they are in the build tree, and this
package adds the first of these to its search path (__path__):
  1. $GEL_PYTHON_STUBS/gel, where GEL_PYTHON_STUBS is protoc's output directory, the one that
     holds gel/v1/ (e.g. build/client/python);
  2. a gel/ directory with v1/ inside on sys.path (e.g. PYTHONPATH=client/python:build/client/python);
  3. build/client/python/gel of the checkout this file is in.
"""
import os
import pkgutil

_package_dir = os.path.dirname(os.path.abspath(__file__))


def _has_stubs(gel_dir):
    return os.path.isfile(os.path.join(gel_dir, "v1", "service_pb2.py"))


def _stub_search_path(package_path):
    search_path = pkgutil.extend_path(list(package_path), __name__)
    explicit = os.environ.get("GEL_PYTHON_STUBS")
    if explicit:
        explicit_gel_dir = os.path.join(os.path.abspath(explicit), "gel")
        if not _has_stubs(explicit_gel_dir):
            raise ImportError(f"gel: GEL_PYTHON_STUBS={explicit} holds no gel/v1/service_pb2.py "
                              "(it should be protoc's output directory, e.g. BUILD/client/python)")
        # Explicit beats whatever else is lying around, e.g. stubs of an older install.
        return [_package_dir, explicit_gel_dir] + [p for p in search_path if p not in (_package_dir, explicit_gel_dir)]
    if not any(_has_stubs(p) for p in search_path):
        checkout_root = os.path.dirname(os.path.dirname(os.path.dirname(_package_dir)))
        build_tree_gel_dir = os.path.join(checkout_root, "build", "client", "python", "gel")
        if not _has_stubs(build_tree_gel_dir):
            raise ImportError("gel: the generated stubs gel/v1/service_pb2.py were not found; build the "
                              "gel_python_stubs target and set GEL_PYTHON_STUBS=BUILD/client/python "
                              f"(looked in {', '.join(search_path + [build_tree_gel_dir])})")
        search_path.append(build_tree_gel_dir)
    return search_path


__path__ = _stub_search_path(__path__)

from .errors import GelError, InvalidRequestError, JobNotFoundError  # noqa: E402
from .client import Client, SubmittedJob, connect  # noqa: E402
from .configuration import read_configuration  # noqa: E402
from .curves import CURVE_COLUMNS, JOB_CURVE_COLUMNS, PROFILE_COLUMNS  # noqa: E402

__all__ = ["connect", "Client", "SubmittedJob", "read_configuration", "CURVE_COLUMNS", "JOB_CURVE_COLUMNS", "PROFILE_COLUMNS",
           "GelError",
           "JobNotFoundError", "InvalidRequestError"]
