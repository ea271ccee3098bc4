"""Exceptions of the gel package. A failed call to geld raises GelError (or a subclass) whose text
is gelctl's one line, "CODE: message", e.g. "NOT_FOUND: job job-000042 not found"."""


class GelError(Exception):
    """A call to geld failed. `code` is the gRPC status name ("UNAVAILABLE", ...), `details` geld's text."""

    def __init__(self, code, details, job_id=None):
        super().__init__(f"{code}: {details}")
        self.code = code
        self.details = details
        self.job_id = job_id


class JobNotFoundError(GelError, LookupError):
    """geld has no job with this id (NOT_FOUND)."""


class InvalidRequestError(GelError, ValueError):
    """geld refused a request field (INVALID_ARGUMENT); `details` starts with the field's dotted
    name, e.g. "scene.generator.lx: must be positive, got -5"."""


def error_from_rpc(rpc_error, address, job_id=None):
    """The GelError for a grpc.RpcError from a call to geld at `address`."""
    code = rpc_error.code().name
    details = rpc_error.details() or ""
    if code == "NOT_FOUND":
        return JobNotFoundError(code, details, job_id)
    if code == "INVALID_ARGUMENT":
        return InvalidRequestError(code, details, job_id)
    if code == "UNAVAILABLE" and not details.startswith("geld "):
        # gRPC's own text ("failed to connect to all addresses") says neither which daemon nor
        # how to choose another; geld's own (shutting down) starts with "geld".
        details = (f"no geld answers at {address} ({details}): start geld there, or give its HOST:PORT "
                   "to gel.connect() or in $GELD_SERVER")
    return GelError(code, details, job_id)
