/// @file shape_io.hpp
/// Reading and writing shape models as text: Wavefront OBJ and the PDS "v/f" table of the Bennu
/// radar model (`101955bennu.tab`, docs/model.md "Gravity"), so that C++ programs can load the
/// asteroid without Python.
///
/// Formats (chosen by the file's extension, case-insensitive):
/// - `.tab` (PDS v/f table): lines `v x y z` (exactly three coordinates) and `f i j k` (exactly three
///   1-based vertex indices), blank lines and `#` comments; nothing else.
/// - `.obj` and any other extension (Wavefront OBJ, a superset of the table): `v x y z [w ...]` (the
///   first three numbers are the coordinates; further numbers, e.g. a weight or a vertex colour, must
///   be numbers and are ignored); `f a b c ...` whose tokens may be `i`, `i/t`, `i//n` or `i/t/n`
///   (only the vertex index i is used); indices are 1-based, a negative index -m refers to the m-th
///   vertex defined so far counting back from the last (OBJ's relative indices), 0 is an error.
///   A face with n > 3 vertices is split into the fan (v1, v_i, v_{i+1}), i = 2..n-1, which is a
///   valid triangulation of convex planar polygons only; the resulting mesh is validated like any
///   other (Shape's checks). Records `vn vt vp g o s l usemtl mtllib` are ignored; any other record
///   is an error.
///
/// Differences from the Python loader (`tubempc.scenario.shapes.load_shape`): OBJ polygons are triangulated
/// here (Python rejects them), and index 0 is always an error here (Python then reads the whole file
/// as 0-based). Both read the files `tubempc.scenario.shapes.save_shape` and save_obj write identically.
///
/// Errors are std::invalid_argument with a message `<path>:<line>: <what>` (the line of the
/// offending record: bad number, wrong number of tokens, index out of range, unknown record,
/// non-finite coordinate, and the mesh errors of Shape mapped back to the face's or vertex's line),
/// or `<path>: <what>` when no line applies (missing or unreadable file, no vertices or no faces).
#pragma once

#include <string>

#include "tubempc/gravity/shape.hpp"

namespace tubempc::gravity {

/// Reads a shape file (see the file comment for the formats) into a validated Shape in metres.
/// @param path       OBJ (`.obj` or other extension) or PDS v/f table (`.tab`) file.
/// @param unit_scale metres per file unit (1000 for coordinates in km, 1 for metres), finite and > 0.
/// @param repair     ShapeRepair::Orient flips inconsistently oriented or inward faces instead of
///                   rejecting them.
/// @return the validated closed mesh, coordinates in metres (file value times unit_scale).
/// @throws std::invalid_argument naming the file and line (see the file comment), or for a bad
///         unit_scale.
Shape load_shape(const std::string& path, double unit_scale, ShapeRepair repair = ShapeRepair::None);

/// Writes a shape as OBJ: a `#` comment line, then `v x y z` lines (coordinates divided by
/// unit_scale, 17 significant digits) and `f i j k` lines (1-based), which load_shape(path,
/// unit_scale) reads back exactly when unit_scale is 1 (and to within one rounding otherwise).
/// @param path       file to create or overwrite.
/// @param shape      the mesh (metres).
/// @param unit_scale metres per file unit (1000: written in km), finite and > 0.
/// @throws std::invalid_argument for a bad unit_scale; std::runtime_error naming the path when the
///         file cannot be written.
void save_obj(const std::string& path, const Shape& shape, double unit_scale = 1.0);

}  // namespace tubempc::gravity
