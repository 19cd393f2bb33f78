#pragma once
/// A small picture of a mesh for overview pages: an orthographic side view rasterized in
/// software (z-buffer, flat Lambert shading), encoded as PNG. No GPU or display needed; the
/// bytes depend only on the mesh and the parameters.

#include <string>

#include "core/mesh.h"
#include "skeleton/skeleton.h"

namespace sm {

struct ThumbnailParams {
  int size = 256;                  ///< width and height of the picture (pixels)
  int supersample = 2;             ///< samples per pixel along each axis (1 = none)
  double azimuth_degrees = 30.0;   ///< view direction around the up axis (0: looking along +y)
  double elevation_degrees = 10.0; ///< view direction above the horizon
  double margin = 0.05;            ///< empty border, relative to the picture's size
};

/// The mesh seen from the side (up is up), fitted to the picture, as PNG bytes (RGB, white
/// background). An empty mesh gives a blank picture. Throws InvalidInputError when size is
/// outside 8..4096 or supersample outside 1..4.
std::string render_thumbnail_png(const Mesh& mesh, UpAxis up, const ThumbnailParams& params = {});

}  // namespace sm
