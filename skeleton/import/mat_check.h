#pragma once
/// A MAT file's structure checked before libmatio reads it (internal to skeleton/import).
///
/// libmatio allocates what a file's headers declare before it reads the data: a 371-byte file
/// declaring a struct of millions of elements took 4 GB and minutes inside
/// Mat_VarReadNextInfo (fuzz/fuzz_skeleton_mat.cpp). This walk over a v5 file's data elements
/// (inflating compressed ones, at most 1 GiB in all) refuses, naming the byte offset, anything
/// whose declared sizes its bytes cannot hold: an element running past its parent, more struct
/// fields or cells than 8-byte tags fit, numeric arrays with fewer bytes than elements, nesting
/// deeper than 32. v7.3 files (HDF5) are left to libmatio and the HDF5 library; MATLAB 4
/// files, which TreeQSM never writes, are refused.

#include <string>
#include <string_view>

namespace sm {

/// Throws InvalidInputError naming `name`, the byte offset and the rule.
void check_mat_structure(std::string_view bytes, const std::string& name);

}  // namespace sm
