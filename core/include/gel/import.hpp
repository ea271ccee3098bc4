#pragma once
// Configurations in from the formats other programs write (docs/gelsim.md "Data in"): a frame of
// a GSD file (HOOMD-blue, gsd.hoomd, and gelsim's own exports and trajectories) or of an
// extended XYZ file (ASE, OVITO, gelsim export). One reader per format, each in its own file
// under src/import/. read_configuration (gel/configuration.hpp) picks the reader by the file's
// ending.
//
// What cannot become a 2D gel of identical disks of radius a is refused, naming the file, the
// frame and the field: a 3D or sheared box, particles out of the plane or of another size, a
// rotation about another axis than z, walls without their positions, bonds the format lost.
#include <cstdint>
#include <string>

#include "gel/configuration.hpp"

namespace gel::importing {

// `frame` counts from 0, or from the end when negative (kLastFrame = -1: the last frame).
// Throws InvalidArgument (field "path" for the file, "frame" for a frame out of range).
Configuration read_gsd(const std::string& path, std::int64_t frame = kLastFrame);
Configuration read_extended_xyz(const std::string& path, std::int64_t frame = kLastFrame);

// The frame index that `frame` names among `count` frames; throws InvalidArgument (field
// "frame") when there is no such frame.
std::uint64_t resolve_frame(const std::string& path, std::int64_t frame, std::uint64_t count);

}  // namespace gel::importing
