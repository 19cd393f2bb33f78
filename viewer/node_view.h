#pragma once
/// What the node panel shows for a selected node: its 2D particle cloud in the node frame,
/// coloured like the strands, with the boundary loop the contours stage would select, and the
/// node's figures. Pure data, so the panel's content is tested without a display.

#include <cstdint>
#include <string>
#include <vector>

#include "particles/particles.h"
#include "skeleton/skeleton.h"
#include "viewer/scene.h"

namespace sm::viewer {

struct NodeCloud {
  NodeId node;
  double radius = 0;                    ///< skeleton radius (metres)
  double disc_radius = 0;               ///< the disc the particles are confined to (metres; 0 if unknown)
  std::uint32_t particles = 0;          ///< particle count (= strands through the node)
  std::uint32_t steps = 0;              ///< relaxation steps taken
  std::uint32_t new_strands = 0;        ///< strands that start at this node
  std::uint32_t from_main = 0;          ///< particles carried from the main child
  std::uint32_t from_lateral = 0;       ///< particles carried from the lateral child
  int children = 0;                     ///< 0 tip, 1 chain, 2 fork
  std::int64_t source_id = -1;          ///< id in the input file (-1: inserted node)
  std::vector<glm::dvec2> points;       ///< #K 2D positions (metres, x along frame.normal, y along binormal)
  std::vector<Rgba8> colors;            ///< #K, same colouring as the strands layer
  std::vector<StrandId> strands;        ///< #K strand of each particle
  std::vector<std::uint32_t> boundary;  ///< indices into points: the outer loop, counter-clockwise
  std::string boundary_error;           ///< set when the boundary could not be computed
};

/// The cloud of `node`. Throws InvalidInputError when the node does not exist or the field
/// was not computed for this skeleton.
NodeCloud node_cloud(const Skeleton& s, const ParticleField& f, NodeId node, StrandColoring coloring,
                     double concave_turn_degrees);

/// One line per figure ("radius 0.0312 m", ...), as the panel prints them.
std::vector<std::string> node_summary(const Skeleton& s, const NodeCloud& cloud);

}  // namespace sm::viewer
