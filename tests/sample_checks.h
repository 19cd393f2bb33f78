#pragma once
// The default pipeline's figures on a tree checked as `strandmesh check --skeleton FILE` checks
// them, against the skeleton as the file gives it, and the regression bounds the sample tests
// hold them to (test_pipeline.cpp, test_samples_slow.cpp).

#include <gtest/gtest.h>

#include <cstddef>

#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "skeleton/build.h"

namespace sm::test {

/// The mesh of `raw` by the pipeline with `params`, checked against input_skeleton(raw).
inline MeshCheckReport mesh_and_check_against_input(const RawSkeleton& raw, const PipelineParams& params = {}) {
  const PipelineResult r = run_pipeline(raw, params);
  const Skeleton input = input_skeleton(raw);
  MeshCheckParams cp;
  cp.skeleton = &input;
  return check_mesh(r.mesh.mesh, cp);
}

/// One closed, oriented 2-manifold in one piece, with thick nodes to measure.
inline void expect_one_sound_piece(const MeshCheckReport& rep) {
  EXPECT_TRUE(rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_GT(rep.thick_nodes, 0u);
}

/// Self-intersecting pairs, fidelity p95 and thick nodes outside at most these.
inline void expect_within(const MeshCheckReport& rep, std::size_t pairs, double p95, std::size_t outside) {
  EXPECT_LE(rep.self_intersecting_pairs, pairs);
  EXPECT_LE(rep.fidelity_p95, p95);
  EXPECT_LE(rep.thick_nodes - rep.thick_nodes_inside, outside);
}

}  // namespace sm::test
