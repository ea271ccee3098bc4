"""A connection to geld: submit, follow, list and cancel jobs, fetch their curves, query the curves of many."""
import copy
import json
import math
import numbers
import os
import re

import grpc

from . import curves
from .errors import error_from_rpc
from .messages import job_to_dict, message_to_dict, state_name, update_to_dict
from .v1 import scene_pb2, service_pb2, service_pb2_grpc

DEFAULT_ADDRESS = "127.0.0.1:50051"

# Curves of large ensembles exceed gRPC's 4 MiB default for a received message; gelctl allows 256 MiB too.
_MAX_RECEIVE_BYTES = 256 * 1024 * 1024

_STATE_NAMES = ("queued", "running", "succeeded", "failed", "cancelled")


def _token_from_environment():
    # gelctl's order: the first line of $GELD_TOKEN_FILE, else $GELD_TOKEN.
    token_file = os.environ.get("GELD_TOKEN_FILE")
    if token_file:
        return read_token_file(token_file)
    return os.environ.get("GELD_TOKEN") or None


def read_token_file(path):
    """The bearer token in the first line of `path` (geld --token-file's format)."""
    with open(path, encoding="utf-8") as token_file:
        return token_file.readline().strip()


# gRPC's own target forms name their transport; anything else must be HOST:PORT, because a bare
# host is dialled on a port geld does not listen on. The same rule as gelctl's --server.
_TARGET_SCHEMES = ("unix:", "unix-abstract:", "dns:", "ipv4:", "ipv6:", "vsock:")
_HOST_PORT = re.compile(r"^(\[[^\]]+\]|[^:\[\]]+):([0-9]{1,5})$")


def _require_host_port(address, source):
    if address.startswith(_TARGET_SCHEMES):
        return
    match = _HOST_PORT.match(address)
    if not match or not 1 <= int(match.group(2)) <= 65535:
        raise ValueError(f"connect: {source} {address!r} is not HOST:PORT (geld listens on {DEFAULT_ADDRESS} "
                         "unless started with another --listen)")


def _read_bytes(path):
    with open(path, "rb") as pem_file:
        return pem_file.read()


def connect(address=None, token=None, *, token_file=None, timeout=30.0, tls_ca=None, tls_cert=None,
            tls_key=None):
    """A Client for the geld at `address` ("HOST:PORT"; default $GELD_SERVER, else 127.0.0.1:50051).

    token: the bearer token of a geld started with --token-file; when neither it nor `token_file`
    is given, it is read as gelctl reads it: the first line of $GELD_TOKEN_FILE, else $GELD_TOKEN.
    timeout: seconds per call (not for watch(), which lasts as long as the job).
    tls_ca: PEM file of the CA that signed geld's --tls-cert (default $GELD_TLS_CA): talk TLS;
    tls_cert, tls_key: this client's certificate and key, for a geld with --tls-client-ca.
    Nothing is sent until the first call, so an unreachable geld shows there (GelError UNAVAILABLE).
    An address that is not HOST:PORT (or one of gRPC's unix:, dns:, ipv4:, ipv6: forms) raises
    ValueError: a bare host would be dialled on a port no geld listens on.
    """
    source = "address" if address else "$GELD_SERVER"
    address = address or os.environ.get("GELD_SERVER") or DEFAULT_ADDRESS
    _require_host_port(address, source)
    if token is None:
        token = read_token_file(token_file) if token_file else _token_from_environment()
    tls_ca = tls_ca or os.environ.get("GELD_TLS_CA") or None
    options = [("grpc.max_receive_message_length", _MAX_RECEIVE_BYTES)]
    if tls_ca:
        if (tls_cert is None) != (tls_key is None):
            raise ValueError("connect: tls_cert and tls_key go together")
        credentials = grpc.ssl_channel_credentials(
            root_certificates=_read_bytes(tls_ca),
            private_key=_read_bytes(tls_key) if tls_key else None,
            certificate_chain=_read_bytes(tls_cert) if tls_cert else None)
        channel = grpc.secure_channel(address, credentials, options=options)
    else:
        if tls_cert or tls_key:
            raise ValueError("connect: tls_cert/tls_key need tls_ca (the CA of geld's certificate)")
        channel = grpc.insecure_channel(address, options=options)
    return Client(channel, address, token, timeout)


def _json_number(value):
    # numpy scalars (a seed sweep over numpy.arange) are numbers to the caller; json needs them as Python's.
    if isinstance(value, numbers.Real) and hasattr(value, "item"):
        return value.item()
    raise TypeError(f"submit: {value!r} ({type(value).__name__}) cannot go into a scene")


def _require_finite(value, name):
    """Raises ValueError naming the field when `value` (a scene dict or one of its values) holds a
    NaN or an infinity: json.dumps would write them as NaN/Infinity, which JSON does not have, and
    geld could only say that the text is not JSON."""
    if isinstance(value, dict):
        for key, item in value.items():
            _require_finite(item, f"{name}.{key}")
    elif isinstance(value, (list, tuple)):
        for index, item in enumerate(value):
            _require_finite(item, f"{name}[{index}]")
    elif isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral) and not math.isfinite(value):
        raise ValueError(f"submit: {name}: must be a finite number, got {value!r}")


def _set_dotted(scene, dotted_name, value):
    node = scene
    *parents, leaf = dotted_name.split(".")
    for key in parents:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    node[leaf] = value


# QueryCurves' parameter filters: gelctl query --where's operators (client/gelctl/cmd_query.cpp),
# looked for in its order, and the ParameterFilter field each one sets.
_WHERE_OPERATORS = ((">=", "min"), ("<=", "max"), ("=", "equals"))


def _where_bound(where, text):
    # As gelctl's where_bound: the whole text a finite number, else bad input naming the filter.
    try:
        value = float(text)
    except (TypeError, ValueError):
        value = None
    if value is None or isinstance(text, bool) or not math.isfinite(value):
        raise ValueError(f"query_curves: where {where!r}: {text!r} is not a number")
    return value


def _where_equals_text(value):
    # geld compares `equals` with the resolved scene's field as text, or as a number when the text
    # is one; booleans are stored as "true"/"false" (server/gelcore_adapter.cpp, flatten).
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    if isinstance(value, str):
        return value
    raise TypeError(f"query_curves: where: {value!r} ({type(value).__name__}) is not a string or number")


def _parameter_filter(where):
    """One `where` item -> gel.v1.ParameterFilter (see Client.query_curves)."""
    if isinstance(where, service_pb2.ParameterFilter):
        return where
    if isinstance(where, str):
        for operator, _ in _WHERE_OPERATORS:
            field, found, text = where.partition(operator)
            if found:
                break
        else:
            raise ValueError(f"query_curves: where {where!r} is not field=value, field>=x or field<=x")
    elif isinstance(where, (tuple, list)) and len(where) == 3:
        field, operator, text = where
        operator = "=" if operator == "==" else operator
        if not isinstance(field, str) or operator not in {op for op, _ in _WHERE_OPERATORS}:
            raise ValueError(f"query_curves: where {where!r} is not (field, op, value) with op '=', '>=' or '<='")
    else:
        raise TypeError(f"query_curves: where {where!r} is not \"field=value\", \"field>=x\", \"field<=x\", "
                        "(field, op, value) or a gel.v1.ParameterFilter")
    request_field = dict(_WHERE_OPERATORS)[operator]
    if request_field == "equals":
        # An empty field goes to geld as it is: geld names it (INVALID_ARGUMENT parameters[i].field).
        return service_pb2.ParameterFilter(field=field, equals=_where_equals_text(text))
    return service_pb2.ParameterFilter(field=field, **{request_field: _where_bound(where, text)})


def _query_labels(labels):
    # {key: value}, or gelctl's --label form: "key=value" or a list of them.
    if labels is None:
        return {}
    if isinstance(labels, dict):
        return {str(key): str(value) for key, value in labels.items()}
    plain = {}
    for label in [labels] if isinstance(labels, str) else labels:
        key, found, value = label.partition("=")
        if not found or not key:
            raise ValueError(f"query_curves: label {label!r} is not key=value")
        plain[key] = value
    return plain


def _study_to_dict(study):
    out = message_to_dict(study)
    out["state"] = state_name(study.state)
    for job, entry in zip(study.jobs, out.get("jobs", [])):
        entry["state"] = state_name(job.state)
    return out


class SubmittedJob(str):
    """What Client.submit returns: the job id (a str, "job-000001"), with `cached`: True when
    geld answered from its run cache with an earlier job that already has these results (nothing
    was queued; the submission's labels, and its name if the job had none, were put on that job)."""

    cached = False

    def __new__(cls, job_id, cached=False):
        submitted = super().__new__(cls, job_id)
        submitted.cached = bool(cached)
        return submitted


class Client:
    """geld's API as Python calls. Made by connect(); usable as a context manager (closes the channel).

    Every failed call raises gel.GelError ("CODE: message", as gelctl prints it):
    JobNotFoundError for an unknown job id, InvalidRequestError for a field geld refuses."""

    def __init__(self, channel, address, token, timeout):
        self._channel = channel
        self._stub = service_pb2_grpc.GelServiceStub(channel)
        self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        self.address = address
        self.timeout = timeout

    def close(self):
        self._channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exception):
        self.close()

    def _call(self, method, request, job_id=None):
        try:
            return method(request, metadata=self._metadata, timeout=self.timeout)
        except grpc.RpcError as error:
            raise error_from_rpc(error, self.address, job_id) from None

    def _all_pages(self, method, request, items):
        """Every page of a list call (ListJobs, ListStudies): items(response) of each, in order."""
        found = []
        while True:
            response = self._call(method, request)
            found.extend(items(response))
            if not response.next_page_token:
                return found
            request.page_token = response.next_page_token

    def submit(self, scene, *, seeds=None, name="", labels=None, fidelity=None, overrides=None, rerun=False):
        """Submit a compression job; returns its id ("job-000001"), a str with `cached` (see
        SubmittedJob): True when the run cache answered with an earlier job.

        scene: a scene preset name ("quick", "paper-bond1", "paper-bond2", ...), a dict in the
          JSON form of gel.v1.Scene (as `gelctl submit --scene` files: {"preset": "quick",
          "compression": {"steps": 3}}; lengths in a, times in t0), or a gel.v1.Scene message.
        seeds: a seed or a list of seeds; several make an ensemble, one member per seed.
          None: the scene's own generator.seed.
        name, labels: the job's name and {key: value} labels (strings), for jobs() and queries.
        fidelity: compression.fidelity ("fast", "default", "paper", "quasistatic").
        overrides: {"dotted.field": value} applied to the scene, as gelctl's --set
          ({"compression.steps": 3, "generator.lx": 30}). A NaN or infinity in the scene or the
          overrides raises ValueError naming the field, before anything is sent.
        rerun: run even when a job with the same resolved scene, seeds and program version
          already succeeded; otherwise geld returns that job's id (the run cache, `cached`),
          with these labels added to it (a key it has with another value: InvalidRequestError).
        """
        request = service_pb2.SubmitJobRequest(name=name, labels=labels or {}, rerun=rerun)
        if seeds is not None:
            request.seeds.extend([int(seeds)] if isinstance(seeds, numbers.Integral) else [int(s) for s in seeds])
        if isinstance(scene, scene_pb2.Scene):
            if fidelity or overrides:
                scene = message_to_dict(scene)
            else:
                request.scene.CopyFrom(scene)
        if not request.HasField("scene"):
            # A copy: the caller's dict is theirs to reuse.
            scene_dict = {"preset": scene} if isinstance(scene, str) else copy.deepcopy(scene)
            if fidelity:
                _set_dotted(scene_dict, "compression.fidelity", fidelity)
            for dotted_name, value in (overrides or {}).items():
                _set_dotted(scene_dict, dotted_name, value)
            _require_finite(scene_dict, "scene")
            # As JSON text, so that geld resolves presets and names a bad field ("scene_json: ...").
            request.scene_json = json.dumps(scene_dict, default=_json_number)
        response = self._call(self._stub.SubmitJob, request)
        return SubmittedJob(response.job_id, response.cached)

    def job(self, job_id):
        """One job as a dict (see gel.messages.job_to_dict): id, name, state, seeds, particles, rows, ..."""
        return job_to_dict(self._call(self._stub.GetJob, service_pb2.GetJobRequest(job_id=job_id), job_id))

    def jobs(self, *, state=None, label=None, name=None):
        """Every job geld has, newest first, as dicts (job()'s keys); pandas.DataFrame(client.jobs())
        makes a table. state: "queued", "running", "succeeded", "failed" or "cancelled";
        label: "key=value" or "key" (has the label); name: exact name."""
        request = service_pb2.ListJobsRequest(label=label or "", name=name or "", page_size=1000)
        if state:
            if state not in _STATE_NAMES:
                raise ValueError(f"jobs: unknown state {state!r} ({', '.join(_STATE_NAMES)})")
            request.state = service_pb2.JobState.Value("JOB_STATE_" + state.upper())
        return self._all_pages(self._stub.ListJobs, request, lambda response: map(job_to_dict, response.jobs))

    def watch(self, job_id):
        """Follow a job: yields one dict per update (gel.messages.update_to_dict), first a
        "snapshot" (the job now) and the rows stored so far, then "state", "progress", "row" and
        "log" updates as they happen; the iteration ends when the job has ended (the last "state"
        dict says how: state "succeeded", "failed" or "cancelled"). Stopping the iteration early
        closes the stream. Being a generator, it calls geld at the first iteration: that is where an
        unknown job id raises JobNotFoundError."""
        stream = self._stub.WatchJob(service_pb2.WatchJobRequest(job_id=job_id), metadata=self._metadata)
        try:
            for update in stream:
                yield update_to_dict(update)
        except grpc.RpcError as error:
            raise error_from_rpc(error, self.address, job_id) from None
        finally:
            stream.cancel()

    def cancel(self, job_id):
        """Cancel a queued or running job; returns the job (dict). A job that already ended:
        GelError FAILED_PRECONDITION."""
        return job_to_dict(self._call(self._stub.CancelJob, service_pb2.CancelJobRequest(job_id=job_id), job_id))

    def _curve(self, job_id):
        return self._call(self._stub.GetCurve, service_pb2.GetCurveRequest(job_id=job_id), job_id)

    def curve(self, job_id):
        """The job's P_y(phi) curve so far as a pandas.DataFrame, one row per equilibrium of each
        member: columns gel.CURVE_COLUMNS, i.e. member and seed, then the engine's curve.csv columns
        with units ("phi [1]", "P [F0/a^2]", "stored_energy [F0 a]", "steps [count]", ...)."""
        return curves.curve_frame(self._curve(job_id))

    def curve_arrays(self, job_id):
        """curve()'s columns as {name: numpy array}, plus gel.PROFILE_COLUMNS: "phi_profile [1]"
        and "sigma_xx_profile [F0/a^2]", "sigma_yy_profile [F0/a^2]", "sigma_xy_profile [F0/a^2]",
        (rows, slices) arrays per slice along y, bottom to top."""
        return curves.curve_arrays(self._curve(job_id))

    def ensemble_curve(self, job_id):
        """An ensemble's mean and sample standard deviation per phi_k as a pandas.DataFrame: k, n
        (members that reached phi_k), "phi [1]", "phi_std [1]", "P [F0/a^2]", "P_std [F0/a^2]", ...
        Empty for a single-seed job."""
        return curves.ensemble_frame(self._curve(job_id))

    def _query(self, bond_preset, labels, where, state, limit):
        if isinstance(where, (str, tuple, service_pb2.ParameterFilter)):
            where = [where]  # one filter; a list of 3 items stays a list of filters
        request = service_pb2.QueryCurvesRequest(
            bond_preset=bond_preset or "", labels=_query_labels(labels),
            parameters=[_parameter_filter(item) for item in where or ()])
        if state:
            if state not in _STATE_NAMES:
                raise ValueError(f"query_curves: unknown state {state!r} ({', '.join(_STATE_NAMES)})")
            request.state = service_pb2.JobState.Value("JOB_STATE_" + state.upper())
        if limit is not None:
            if isinstance(limit, bool) or not isinstance(limit, numbers.Integral):
                raise TypeError(f"query_curves: limit {limit!r} is not an integer")
            # geld refuses < 0 (INVALID_ARGUMENT) and caps at 1000; beyond int32 it is 1000 all the same.
            request.limit = min(int(limit), 1000) if limit > 0 else max(int(limit), -1)
        return self._call(self._stub.QueryCurves, request)

    def query_curves(self, *, bond_preset=None, labels=None, where=None, limit=None, state=None):
        """The curves of many jobs at once (QueryCurves, gelctl query): a list of (job, curve), newest
        job first, where job is a dict as job() returns and curve a pandas.DataFrame as curve()
        returns (every member of the job, columns gel.CURVE_COLUMNS). All the criteria must hold:

        bond_preset: "bond1" or "bond2" (the resolved scene's bond.preset); None: any.
        labels: {key: value}, or gelctl's --label form "key=value" or a list of them; every one
          must be among the job's labels.
        where: filters on the job's resolved scene, by dotted field name; one filter or a list of
          them, each either
            a string in gelctl's --where syntax: "field=value", "field>=x" or "field<=x"
              ("generator.seed=1", "generator.lx>=30", "compression.fidelity=fast");
            a tuple (field, op, value), op "=" (or "=="), ">=" or "<=":
              ("generator.lx", ">=", 30), ("bond.preset", "=", "bond2");
            or a gel.v1.ParameterFilter.
          "=" matches the field's text or, when value is a number, its numeric value (booleans are
          "true"/"false"); ">=" and "<=" compare numbers and need a finite number. generator.seed
          matches any member's seed of an ensemble.
        limit: jobs at most; None (or 0): geld's default, 100; more than 1000 is 1000 (geld's cap).
        state: "succeeded" (None: the default), "failed", "cancelled", "running" or "queued".

        A `where` or `labels` item that is not of these forms raises ValueError (TypeError for a
        wrong type) before anything is sent; what geld refuses (an empty field name, as in "=1", a
        field the scene does not have, named with the ones it has, or a negative limit) raises
        gel.InvalidRequestError (code INVALID_ARGUMENT)."""
        response = self._query(bond_preset, labels, where, state, limit)
        return [(job_to_dict(entry.job), curves.curve_frame(entry.curve)) for entry in response.curves]

    def query_curves_frame(self, *, bond_preset=None, labels=None, where=None, limit=None, state=None):
        """query_curves()'s curves as one pandas.DataFrame: columns gel.JOB_CURVE_COLUMNS, i.e.
        job_id, then curve()'s (member, seed, "phi [1]", "P [F0/a^2]", ...), the rows of each job
        in the order of query_curves() (newest job first). Arguments and errors as query_curves();
        no matching job: an empty table with these columns. For the jobs' other fields,
        pandas.DataFrame(job for job, _ in client.query_curves(...)) makes a table to merge on its id."""
        response = self._query(bond_preset, labels, where, state, limit)
        return curves.jobs_curve_frame([(entry.job.id, entry.curve) for entry in response.curves])

    def analysis(self, job_id, *, include_unequilibrated=False):
        """The curve analysis geld computes for a finished job (GetAnalysis, gelctl analysis) as a
        dict: members; rows and intervals (name -> {mean, std, members}, over the members); the
        power_law and gel_point fits (None with power_law_error / gel_point_error when they
        fail), with the phi range and rows they used; excluded_rows with their reasons; regimes
        (boundaries and per-interval rates, energy increments also in E0); E0 in F0 a. Only rows
        that every member reached at equilibrium with a spanning network are fitted, unless
        include_unequilibrated. A job that has not succeeded raises gel.GelError
        (FAILED_PRECONDITION)."""
        request = service_pb2.GetAnalysisRequest(job_id=job_id, include_unequilibrated=include_unequilibrated)
        return json.loads(self._call(self._stub.GetAnalysis, request, job_id).json)

    def analysis_rows(self, job_id, *, include_unequilibrated=False):
        """analysis()'s per-row ensemble means as a pandas.DataFrame, one row per phi_k: a column
        per observable (phi, P, contact_number, ...) and its standard deviation over the members
        as <name>_std."""
        import pandas
        rows = self.analysis(job_id, include_unequilibrated=include_unequilibrated)["rows"]
        columns = {}
        for name, values in rows.items():
            columns[name] = values["mean"]
            columns[name + "_std"] = values["std"]
        return pandas.DataFrame(columns)

    def submit_study(self, preset=None, *, ensembles=None, seeds=None, fidelity=None, name="", labels=None, rerun=False):
        """Submit a study (SubmitStudy, gelctl study submit); returns its id ("study-000001").

        preset: a built-in study, "paper" (bond 1 and bond 2 at paper size, 10 seeds, fidelity
          quasistatic) or "quick" (both bonds on the quick scene, 3 seeds); or
        ensembles: {name: scene} with scenes as submit() takes them as dicts or preset names,
          e.g. {"bond1": {"preset": "quick"}, "bond2": {"preset": "quick", "bond": {"preset": "bond2"}}}.
        seeds: seeds 1..N for every ensemble (default: the preset's; without a preset, each
          scene's own seed). fidelity: the preset's fidelity. name, labels, rerun: as submit()."""
        request = service_pb2.SubmitStudyRequest(name=name or (preset or ""), labels=labels or {}, rerun=rerun,
                                                 preset=preset or "", fidelity=fidelity or "",
                                                 seed_count=int(seeds or 0))
        for ensemble_name, scene in (ensembles or {}).items():
            scene_dict = {"preset": scene} if isinstance(scene, str) else copy.deepcopy(scene)
            request.ensembles.add(name=ensemble_name, scene_json=json.dumps(scene_dict, default=_json_number))
        return self._call(self._stub.SubmitStudy, request).study_id

    def study(self, study_id):
        """A study as a dict (the gel.v1.Study message's fields): id, name, preset, state, jobs
        (per ensemble: ensemble, job_id, state, members, members_finished, rows, cached), error, ..."""
        study = self._call(self._stub.GetStudy, service_pb2.GetStudyRequest(study_id=study_id))
        return _study_to_dict(study)

    def studies(self):
        """Every study, newest first, as study()'s dicts."""
        request = service_pb2.ListStudiesRequest(page_size=1000)
        return self._all_pages(self._stub.ListStudies, request,
                               lambda response: map(_study_to_dict, response.studies))

    def cancel_study(self, study_id):
        """Cancel the study's jobs that have not ended; returns the study (dict)."""
        return _study_to_dict(self._call(self._stub.CancelStudy, service_pb2.CancelStudyRequest(study_id=study_id)))

    def watch_study(self, study_id):
        """Follow a study until every job has ended: yields dicts with "ensemble", "job_id", and
        either "study" (the study as a dict: first, on every job's state change, and last) or
        "update" (the job's update as watch() gives it)."""
        stream = self._stub.WatchStudy(service_pb2.WatchStudyRequest(study_id=study_id), metadata=self._metadata)
        try:
            for update in stream:
                out = {"ensemble": update.ensemble, "job_id": update.job_id}
                if update.HasField("study"):
                    out["study"] = _study_to_dict(update.study)
                if update.HasField("update"):
                    out["update"] = update_to_dict(update.update)
                yield out
        except grpc.RpcError as error:
            raise error_from_rpc(error, self.address) from None
        finally:
            stream.cancel()

    def study_analysis(self, study_id, *, include_unequilibrated=False, bootstrap_samples=0, partial=False):
        """The study's analysis (GetStudyAnalysis) as a dict, format gel.study-analysis.v1
        (docs/study_analysis.md): per ensemble every observable as {"value", "lo", "hi", "n"}, the
        95 % bootstrap interval over seeds and the number of seeds. A study that has not
        succeeded raises gel.GelError (FAILED_PRECONDITION) unless partial."""
        request = service_pb2.GetStudyAnalysisRequest(study_id=study_id, include_unequilibrated=include_unequilibrated,
                                                      bootstrap_samples=bootstrap_samples, partial=partial)
        return json.loads(self._call(self._stub.GetStudyAnalysis, request).json)

    def logs(self, job_id):
        """The job's log lines as dicts: id, unix_ms, level, message."""
        request = service_pb2.GetLogsRequest(job_id=job_id)
        lines = []
        while True:
            # geld answers at most 1000 lines a call; ask again after the last one until none is left.
            response = self._call(self._stub.GetLogs, request, job_id)
            if not response.lines:
                return lines
            lines.extend({"id": line.id, "unix_ms": line.unix_ms, "level": line.level, "message": line.message}
                         for line in response.lines)
            request.after_id = response.lines[-1].id
