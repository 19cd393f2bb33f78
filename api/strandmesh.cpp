#include "strandmesh/strandmesh.h"

#include <memory>
#include <string>
#include <utility>

#include <tbb/global_control.h>

#include "core/errors.h"
#include "meshio/export.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"

namespace strandmesh {

Skeleton read_skeleton(const std::filesystem::path& path) { return sm::read_skeleton(path); }

Tree mesh_skeleton(const Skeleton& skeleton, const Options& options) {
  if (options.threads < 0) {
    throw sm::InvalidInputError("strandmesh::Options::threads must be >= 0, got " + std::to_string(options.threads));
  }
  sm::PipelineParams params;
  if (!options.config.empty()) params = sm::load_params(options.config);
  if (options.seed) params.particles.seed = *options.seed;
  if (options.spacing) params.particles.spacing = *options.spacing;
  std::unique_ptr<tbb::global_control> limit;
  if (options.threads > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<std::size_t>(options.threads));
  }
  sm::PipelineResult r = sm::run_pipeline(skeleton, params, options.progress);
  if (r.mesh.stats.bad_edges > 0) {
    throw sm::InternalError(skeleton.source + ": the mesh has " + std::to_string(r.mesh.stats.bad_edges) +
                            " edges not shared by exactly two triangles; please report this skeleton");
  }
  Tree tree;
  tree.output = params.output;
  tree.output.up_axis = r.skeleton.skeleton.up_axis;
  tree.output.root = r.skeleton.skeleton.position[0];
  const sm::Warnings warnings = r.warnings();
  for (const sm::Warning& w : warnings.list()) {
    std::string line = w.message + " (" + std::to_string(w.count) + "x";
    for (std::size_t i = 0; i < w.examples.size(); ++i) line += (i == 0 ? "; e.g. " : ", ") + w.examples[i];
    tree.warnings.push_back(line + ")");
  }
  tree.mesh = std::move(r.mesh.mesh);
  return tree;
}

void write_mesh(const Tree& tree, const std::filesystem::path& path) { sm::write_mesh(tree.mesh, path, tree.output); }

}  // namespace strandmesh
