"""gelsim's configuration files (gel.v1.Configuration) as numpy arrays."""
import numpy
from google.protobuf import json_format, message

from .messages import message_to_dict
from .v1 import scene_pb2


def read_configuration(path):
    """A configuration file as a dict: `gelsim generate --out` writes them, and `gelsim compress`
    writes one per equilibrium (snapshots/k_007.pb). As gelsim decides, a name ending in .json is
    Protocol Buffers' JSON mapping and any other name binary protobuf.

    Per particle (length N): x, y [a], theta [rad] (float64), wall (int32: 0 free, 1 bottom,
    2 top; empty before walls exist), vx, vy [a/t0], omega [1/t0] (float64; empty: at rest,
    as a generated gel; a run's snapshots hold the engine's velocities). Per bond (length B): bond_i, bond_j (int32 particle
    indices), bond_bix, bond_biy, bond_bjx, bond_bjy (the contact point on i and on j, unit
    vectors in the particle's body frame: rotate by theta). Box: lx, ly [a], periodic_y (False once
    walls replaced the y boundary), wall_bottom, wall_top [a]. Also seed, format_version,
    program_version and generator (the generator's parameters, a dict).
    """
    configuration = scene_pb2.Configuration()
    with open(path, "rb") as config_file:
        content = config_file.read()
    try:
        if str(path).endswith(".json"):
            json_format.Parse(content.decode("utf-8"), configuration)
        else:
            configuration.ParseFromString(content)
    except (json_format.ParseError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not a gel.v1.Configuration in JSON: {error}") from None
    except message.DecodeError as error:
        raise ValueError(f"{path}: not a binary gel.v1.Configuration: {error}") from None

    def floats(values):
        return numpy.array(values, dtype=numpy.float64)

    def ints(values):
        return numpy.array(values, dtype=numpy.int32)

    return {
        "x": floats(configuration.x), "y": floats(configuration.y), "theta": floats(configuration.theta),
        "wall": ints(configuration.wall),
        "vx": floats(configuration.vx), "vy": floats(configuration.vy), "omega": floats(configuration.omega),
        "bond_i": ints(configuration.bond_i), "bond_j": ints(configuration.bond_j),
        "bond_bix": floats(configuration.bond_bix), "bond_biy": floats(configuration.bond_biy),
        "bond_bjx": floats(configuration.bond_bjx), "bond_bjy": floats(configuration.bond_bjy),
        "lx": configuration.lx, "ly": configuration.ly, "periodic_y": configuration.periodic_y,
        "wall_bottom": configuration.wall_bottom, "wall_top": configuration.wall_top,
        "seed": configuration.seed, "format_version": configuration.format_version,
        "program_version": configuration.program_version,
        "generator": message_to_dict(configuration.generator),
    }
