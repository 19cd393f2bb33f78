#pragma once
/// ExportParams as text: the names the CLI and the config's `export` section accept
/// (meshio/param_table.cpp; docs/export.md lists them with what an engine does with each).

#include <optional>
#include <string>
#include <string_view>

#include "meshio/export.h"

namespace sm {

/// Parses "y" or "z" (nullopt for "auto": the format's convention). Throws InvalidInputError.
std::optional<UpAxis> parse_up_axis(std::string_view text);
/// Parses "root", "center" or "origin" (nullopt for "auto"). Throws InvalidInputError.
std::optional<Pivot> parse_pivot(std::string_view text);
/// Parses "meshopt" or "none". Throws InvalidInputError.
Compression parse_compression(std::string_view text);
/// File units per metre from a positive number or a unit name (m 1, cm 100, mm 1000, in
/// 39.37..., ft 3.28...); throws InvalidInputError for anything else.
double parse_scale(std::string_view text);

/// Sets the attribute switches of `params` from a comma-separated list of attribute names
/// (docs/export.md; "none" clears them all, "all" sets them all). Throws InvalidInputError naming
/// an unknown attribute and the accepted ones, with the closest one when there is one.
void set_attributes(std::string_view list, ExportParams& params);
/// The attribute switches of `params` as the list set_attributes reads.
std::string attribute_list(const ExportParams& params);

}  // namespace sm
