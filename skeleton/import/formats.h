#pragma once
/// Readers of measured-tree formats: quantitative structure models (cylinder tables from
/// TreeQSM, SimpleForest, aRchi, rTwig) and OpenAlea MTG files. docs/formats.md is the user's
/// description; skeleton/io.h's read_skeleton() picks the reader.
///
/// Readers only parse: validation stays build_skeleton()'s job, and every node's `where`
/// names its line (or cylinder) for its messages. Values are returned in the file's own units
/// (radii, not diameters); read_skeleton() scales them to metres. Errors are
/// InvalidInputError naming the file, the line and column (or the variable) and the rule.

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "skeleton/skeleton.h"

namespace sm {

/// Column (or MTG feature) names given by the user for the fields a reader looks for:
/// {"radius", "rad_m"}, {"parent", "par"}, ... Fields: id, parent, extension, start_x,
/// start_y, start_z, end_x, end_y, end_z, axis_x, axis_y, axis_z, length, radius, diameter
/// (tables); x, y, z, diameter, radius (MTG).
using ColumnMap = std::vector<std::pair<std::string, std::string>>;

/// The field names ColumnMap accepts, for --help and error messages.
std::string known_column_fields();

/// A cylinder table: CSV (or tab/semicolon/space separated) with a header line naming the
/// columns (SimpleForest, aRchi, rTwig and R exports of TreeQSM: start and end points, or
/// start, axis and length; radius or diameter; id and parent id; optional extension id), or a
/// TreeQSM text export without header (`cyl_data_*.txt`: radius, length, start x y z, axis
/// x y z, parent, extension, ... per line; parents are 1-based line numbers, 0 for the root).
RawSkeleton parse_cylinder_table(std::string_view text, const std::string& name, const ColumnMap& columns = {});

/// A TreeQSM MATLAB file (v5, or v7.3 where libmatio reads HDF5): the first struct variable
/// with a `cylinder` field (`QSM`, `OptQSM`, ...; the first model of an array of them), whose
/// `start`, `axis`, `length`, `radius`, `parent` and `extension` are used; or TreeQSM 2.3's
/// top-level `Rad`, `Len`, `Sta`, `Axe`, `CPar`, `CExt`. Throws IoError when the file cannot
/// be opened as a MAT file.
RawSkeleton read_treeqsm_mat(const std::filesystem::path& path);

/// An OpenAlea (AMAPmod) MTG file: the topology code of the MTG: section (`/` decomposition,
/// `<` successor, `+` branch, `<<` ranges, `^` and tab columns as in the format), with
/// coordinates XX, YY, ZZ (or X, Y, Z, or the features named in `columns`) and a diameter
/// feature (TopDia, Diameter, ...; or a radius). Every entity with coordinates becomes a node,
/// attached to its nearest ancestor in the topology that has coordinates; an entity at
/// exactly its parent's point is that node; a node without a diameter (or with 0) takes its
/// parent's. Radii are returned in the diameter feature's unit.
RawSkeleton parse_mtg(std::string_view text, const std::string& name, const ColumnMap& columns = {});

}  // namespace sm
