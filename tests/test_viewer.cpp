// Viewer tests without a display: scene building, camera and picking, the renderer against
// the mock backend, the parameter table, stage dumps, the app state machine, and the ImGui
// panels run headless (an ImGui context needs no window to lay out and tessellate).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include <imgui.h>
#include <imgui_internal.h>
#include <nlohmann/json.hpp>

#include "contours/dump.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "meshio/export.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "viewer/app.h"
#include "viewer/backend.h"
#include "viewer/camera.h"
#include "viewer/colors.h"
#include "viewer/image.h"
#include "viewer/job.h"
#include "viewer/node_view.h"
#include "viewer/panels.h"
#include "viewer/param_fields.h"
#include "viewer/run.h"
#include "viewer/scene.h"

namespace sm::viewer {
namespace {

using test::built;
using test::temp_dir;

std::size_t li(Layer l) {
  return static_cast<std::size_t>(l);
}

// A closed box mesh (8 vertices, 12 triangles, outward).
Mesh unit_box(glm::dvec3 lo = glm::dvec3(0), glm::dvec3 hi = glm::dvec3(1)) {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

// A two-node branch (root and tip) with a hand-made particle field of three strands:
// strand 0 and 1 start at the tip, strand 2 is new at the root.
struct TinyRun {
  Skeleton skeleton;
  ParticleField field;
};
TinyRun tiny_run() {
  TinyRun t;
  t.skeleton = built(test::straight_branch(2));
  ParticleField& f = t.field;
  f.spacing = 0.02;
  f.neighbour_distance = 0.038;
  f.node_begin = {0, 3, 5};
  // Node 0 (root): the tip's two particles carried, then one new strand.
  f.position = {{0.02, 0.0}, {-0.02, 0.0}, {0.0, 0.03}, {0.015, 0.0}, {-0.015, 0.0}};
  f.strand = {StrandId(0u), StrandId(1u), StrandId(2u), StrandId(0u), StrandId(1u)};
  f.new_begin = {2, 0};
  f.steps = {7, 3};
  f.disc_radius = {0.09, 0.045};
  f.strand_begin = {0, 1, 3};
  f.strand_start = {NodeId(1u), NodeId(1u), NodeId(0u)};
  return t;
}

// ---- colours, layers, parsing -----------------------------------------------------------

TEST(ViewerColors, KeyColorsAreStableAndNeighboursDiffer) {
  EXPECT_EQ(key_color(42), key_color(42));
  for (std::uint64_t k = 0; k < 200; ++k) {
    const Rgba8 a = key_color(k), b = key_color(k + 1);
    const int d = std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
    EXPECT_GT(d, 20) << "keys " << k << " and " << k + 1;
  }
}

TEST(ViewerColors, LegendFollowsVisibleLayers) {
  std::array<bool, kLayerCount> vis{};
  EXPECT_TRUE(legend_entries(vis, StrandColoring::by_strand, false).empty());
  vis[li(Layer::contours)] = true;
  const auto e = legend_entries(vis, StrandColoring::by_strand, false);
  ASSERT_FALSE(e.empty());
  EXPECT_TRUE(std::any_of(e.begin(), e.end(), [](const LegendEntry& x) {
    return x.color == palette::loop_split && x.text.find("split") != std::string::npos;
  }));
  vis[li(Layer::strands)] = true;
  const auto t = legend_entries(vis, StrandColoring::by_tip, false);
  EXPECT_TRUE(
      std::any_of(t.begin(), t.end(), [](const LegendEntry& x) { return x.text.find("tip") != std::string::npos; }));
}

TEST(ViewerParse, LayersSizeCamera) {
  const ViewState v = parse_layers("mesh, strands,uv,legend");
  EXPECT_TRUE(v.visible[li(Layer::mesh)]);
  EXPECT_TRUE(v.visible[li(Layer::strands)]);
  EXPECT_FALSE(v.visible[li(Layer::skeleton)]);
  EXPECT_EQ(v.shading, MeshShading::uv_checker);
  EXPECT_TRUE(v.legend);
  EXPECT_THROW(parse_layers("mesh,bark"), UsageError);
  for (std::size_t i = 0; i < kLayerCount; ++i) {
    EXPECT_EQ(layer_from_name(layer_name(static_cast<Layer>(i))), static_cast<Layer>(i));
  }
  EXPECT_EQ(parse_size("640x480"), (std::array<int, 2>{640, 480}));
  EXPECT_THROW(parse_size("640"), UsageError);
  EXPECT_THROW(parse_size("0x480"), UsageError);
  EXPECT_THROW(parse_size("640x480px"), UsageError);
  const CameraSpec c = parse_camera_spec("yaw=30,pitch=-10,dist=0.5,node=4,fov=40,around=3");
  EXPECT_DOUBLE_EQ(*c.around, 3);
  EXPECT_DOUBLE_EQ(*c.yaw_degrees, 30);
  EXPECT_DOUBLE_EQ(*c.pitch_degrees, -10);
  EXPECT_DOUBLE_EQ(c.distance_scale, 0.5);
  EXPECT_EQ(*c.node, 4u);
  EXPECT_DOUBLE_EQ(*c.fov_degrees, 40);
  EXPECT_THROW(parse_camera_spec("yaw"), UsageError);
  EXPECT_THROW(parse_camera_spec("roll=3"), UsageError);
  EXPECT_THROW(parse_camera_spec("pitch=95"), UsageError);
  EXPECT_THROW(parse_camera_spec("dist=-1"), UsageError);
  EXPECT_THROW(parse_camera_spec("node=1.5"), UsageError);
}

// ---- scene building ----------------------------------------------------------------------

TEST(ViewerScene, SkeletonDiscsFrames) {
  const Skeleton s = built(test::y_fork());
  const glm::dvec3 origin(0.0);
  const auto edges = skeleton_batches(s, origin);
  ASSERT_FALSE(edges.empty());
  EXPECT_EQ(edges[0].primitive, Primitive::lines);
  EXPECT_EQ(edges[0].vertex_count(), 2 * (s.size() - 1));
  // Every edge joins a node to its parent.
  for (std::size_t i = 1, k = 0; i < s.size(); ++i, k += 2) {
    EXPECT_NEAR(glm::length(glm::dvec3(edges[0].positions[k + 1]) - s.position[i]), 0.0, 1e-6);
    EXPECT_NEAR(glm::length(glm::dvec3(edges[0].positions[k]) - s.position[s.parent[i].idx()]), 0.0, 1e-6);
  }
  SceneOptions o;
  o.disc_segments = 12;
  const auto discs = disc_batches(s, origin, o);
  ASSERT_EQ(discs.size(), 1u);
  EXPECT_EQ(discs[0].vertex_count(), s.size() * 12 * 2);
  // Disc vertices lie at the node radius, in the node's cross-section plane.
  for (std::size_t n = 0; n < s.size(); ++n) {
    for (int k = 0; k < 24; ++k) {
      const glm::dvec3 p(discs[0].positions[n * 24 + static_cast<std::size_t>(k)]);
      EXPECT_NEAR(glm::length(p - s.position[n]), s.radius[n], 1e-5);
      EXPECT_NEAR(glm::dot(p - s.position[n], s.frame[n].tangent), 0.0, 1e-5);
    }
  }
  const auto frames = frame_batches(s, origin, o);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].vertex_count(), s.size() * 6);
  EXPECT_EQ(frames[0].colors[0], palette::axis_tangent);
  const glm::dvec3 tip(frames[0].positions[1]);
  EXPECT_NEAR(glm::length(tip - s.position[0]), o.frame_length * s.radius[0], 1e-5);
}

TEST(ViewerScene, GeoreferencedTreeKeepsPrecision) {
  // A tree far from the origin is drawn relative to its bounding-box centre: the local
  // coordinates are the same as for the tree at the origin, to float precision of its size.
  RawSkeleton near = test::y_fork();
  RawSkeleton far = near;
  for (auto& p : far.position) p += glm::dvec3(6.0e5, 5.2e6, 254.0);
  const Skeleton a = built(near), b = built(far);
  const Scene sa = build_scene({.skeleton = &a});
  const Scene sb = build_scene({.skeleton = &b});
  EXPECT_NEAR(sb.origin.z - sa.origin.z, 254.0, 1e-6);
  const auto& pa = sa.layer(Layer::skeleton)[0].positions;
  const auto& pb = sb.layer(Layer::skeleton)[0].positions;
  ASSERT_EQ(pa.size(), pb.size());
  for (std::size_t i = 0; i < pa.size(); ++i) EXPECT_LT(glm::length(pa[i] - pb[i]), 1e-5f);
}

TEST(ViewerScene, ParticlesColouredByStrandOrTip) {
  const TinyRun t = tiny_run();
  SceneOptions o;
  const auto by_strand = particle_batches(t.skeleton, t.field, nullptr, glm::dvec3(0), o);
  ASSERT_EQ(by_strand.size(), 1u);
  const Batch& b = by_strand[0];
  EXPECT_EQ(b.primitive, Primitive::points);
  ASSERT_EQ(b.vertex_count(), 5u);
  // Particle 3 (tip, strand 0) sits at the tip's position plus its 2D offset in the frame.
  const glm::dvec3 expect = t.skeleton.position[1] + t.skeleton.frame[1].to_world(t.field.position[3]);
  EXPECT_LT(glm::length(glm::dvec3(b.positions[3]) - expect), 1e-6);
  // Same strand, same colour at both nodes; different strands differ.
  EXPECT_EQ(b.colors[0], b.colors[3]);
  EXPECT_EQ(b.colors[1], b.colors[4]);
  EXPECT_NE(b.colors[0], b.colors[1]);
  o.strand_coloring = StrandColoring::by_tip;
  const Batch tip = particle_batches(t.skeleton, t.field, nullptr, glm::dvec3(0), o)[0];
  // Strands 0 and 1 start at the same tip: one colour; strand 2 starts at the root.
  EXPECT_EQ(tip.colors[0], tip.colors[1]);
  EXPECT_NE(tip.colors[0], tip.colors[2]);
}

TEST(ViewerScene, ContoursMarkSplitSlices) {
  ContourSet c;
  c.loop_begin = {0, 4, 7};
  c.point = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {1, 0, 1}, {0, 1, 1}, {-1, 0, 1}};
  c.strand.assign(7, StrandId(0u));
  c.loop_node = {NodeId(0u), NodeId(0u)};
  c.loop_t = {0, 1};
  c.loop_distance = {0, 1};
  c.loop_center = {{0, 0, 0}, {0, 0, 1}};
  c.loop_frame = {Frame{}, Frame{}};
  c.loop_radius = {1, 1};
  c.loop_kind = {LoopKind::plain, LoopKind::split};
  const auto batches = contour_batches(c, glm::dvec3(0));
  ASSERT_EQ(batches.size(), 2u);
  EXPECT_EQ(batches[0].vertex_count(), 4u * 2);         // a closed loop of 4 points
  EXPECT_EQ(batches[1].vertex_count(), (3u + 2u) * 2);  // a loop of 3 and a centre cross
  EXPECT_EQ(batches[1].colors[0], palette::loop_split);
  EXPECT_GT(batches[1].line_width, batches[0].line_width);
  EXPECT_NE(batches[1].label.find("split"), std::string::npos);
  // The loop closes: its last segment ends where the first starts.
  EXPECT_EQ(batches[0].positions[7], batches[0].positions[0]);
}

TEST(ViewerScene, MeshWireframeNormals) {
  Mesh m = unit_box();
  const auto tri = mesh_batches(m, glm::dvec3(0.5));
  ASSERT_EQ(tri.size(), 1u);
  EXPECT_EQ(tri[0].primitive, Primitive::triangles);
  EXPECT_EQ(tri[0].vertex_count(), 36u);
  EXPECT_EQ(tri[0].normals.size(), 36u);
  // Normals point away from the centre (smooth normals of a closed, outward box).
  for (std::size_t i = 0; i < 36; ++i) {
    EXPECT_NEAR(glm::length(tri[0].normals[i]), 1.0f, 1e-5f);
    EXPECT_GT(glm::dot(tri[0].normals[i], tri[0].positions[i]), 0.0f);
  }
  const auto wire = wireframe_batches(m, glm::dvec3(0));
  ASSERT_EQ(wire.size(), 1u);
  EXPECT_EQ(wire[0].vertex_count(), 18u * 2);  // 12 box edges + 6 face diagonals, each once
  const auto nrm = normal_batches(m, glm::dvec3(0));
  ASSERT_EQ(nrm.size(), 1u);
  EXPECT_EQ(nrm[0].vertex_count(), 8u * 2);
  m.corner_uvs.assign(m.triangles.size(), {glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(0, 1)});
  EXPECT_EQ(mesh_batches(m, glm::dvec3(0))[0].uvs.size(), 36u);
}

// The unit box and a loose triangle through its top face: 3 boundary edges, and the loose
// triangle crosses the two triangles of the top face.
Mesh box_with_stray_triangle() {
  Mesh m = unit_box();
  const auto v = static_cast<std::uint32_t>(m.positions.size());
  m.positions.push_back({0.5, 0.5, 0.5});
  m.positions.push_back({0.6, 0.5, 1.5});
  m.positions.push_back({0.4, 0.55, 1.5});
  m.triangles.push_back({v, v + 1, v + 2});
  return m;
}

TEST(ViewerScene, ProblemsShowWhatTheChecksFound) {
  const Mesh m = box_with_stray_triangle();
  MeshCheckParams p;
  p.max_examples = 1000;
  const MeshCheckReport r = check_mesh(m, p);
  ASSERT_GT(r.self_intersecting_pairs, 0u);
  ASSERT_EQ(r.boundary_edges, 3u);
  const auto batches = problem_batches(m, nullptr, r, glm::dvec3(0));
  std::set<std::uint32_t> crossing;
  for (const auto& [a, b] : r.self_intersection_examples) crossing.insert({a, b});
  std::size_t fill = 0, edges = 0;
  for (const Batch& b : batches) {
    if (b.label == "self-intersecting triangles") {
      EXPECT_EQ(b.primitive, Primitive::triangles);
      EXPECT_EQ(b.normals.size(), b.vertex_count());
      fill += b.vertex_count();
    }
    if (b.label.find("boundary") != std::string::npos) edges += b.vertex_count();
  }
  EXPECT_EQ(fill, 3 * crossing.size());  // each crossing triangle once
  EXPECT_EQ(edges, 3u * 2);
  // Nothing listed, nothing drawn; indices out of range are skipped.
  EXPECT_TRUE(problem_batches(m, nullptr, MeshCheckReport{}, glm::dvec3(0)).empty());
  MeshCheckReport bad;
  bad.self_intersection_examples = {{0u, 999u}};
  bad.outside_node_examples = {5u};
  bad.boundary_edge_examples = {{0u, 999u}};
  const auto few = problem_batches(m, nullptr, bad, glm::dvec3(0));
  ASSERT_EQ(few.size(), 2u);  // triangle 0 filled and outlined; no nodes without a skeleton
  EXPECT_EQ(few[0].vertex_count(), 3u);
  // Thick nodes outside the mesh are points at the node.
  const Skeleton s = built(test::straight_branch(3));
  bad.outside_node_examples = {1u, 77u};
  const auto with_nodes = problem_batches(m, &s, bad, glm::dvec3(1));
  ASSERT_EQ(with_nodes.size(), 3u);
  EXPECT_EQ(with_nodes[2].primitive, Primitive::points);
  ASSERT_EQ(with_nodes[2].vertex_count(), 1u);
  EXPECT_LT(glm::length(glm::dvec3(with_nodes[2].positions[0]) - (s.position[1] - glm::dvec3(1))), 1e-6);
  // Vertices beyond the fidelity tolerance are small points at the vertex.
  MeshCheckReport far;
  far.fidelity_outlier_examples = {3u, 1000u};
  const auto far_points = problem_batches(m, nullptr, far, glm::dvec3(0));
  ASSERT_EQ(far_points.size(), 1u);
  EXPECT_EQ(far_points[0].primitive, Primitive::points);
  ASSERT_EQ(far_points[0].vertex_count(), 1u);
  EXPECT_EQ(glm::dvec3(far_points[0].positions[0]), m.positions[3]);
}

TEST(ViewerScene, BuildSceneFillsOnlyLayersWithData) {
  const Mesh m = unit_box(glm::dvec3(10), glm::dvec3(12));
  const Scene s = build_scene({.mesh = &m});
  EXPECT_NEAR(s.origin.x, 11.0, 1e-12);
  EXPECT_FALSE(s.layer(Layer::mesh).empty());
  EXPECT_FALSE(s.layer(Layer::wireframe).empty());
  EXPECT_TRUE(s.layer(Layer::skeleton).empty());
  EXPECT_TRUE(s.layer(Layer::strands).empty());
  EXPECT_NEAR(s.bounds.radius(), std::sqrt(3.0), 1e-9);
}

TEST(ViewerScene, SubtreeBoundsAndSelection) {
  const Skeleton s = built(test::y_fork());
  const Bounds all = subtree_bounds(s, Skeleton::root());
  std::size_t fork = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.is_fork(NodeId(i))) fork = i;
  }
  const NodeId lateral = s.children[fork][1];
  ASSERT_TRUE(lateral.valid());
  const Bounds sub = subtree_bounds(s, lateral);
  EXPECT_FALSE(sub.empty());
  EXPECT_LT(sub.radius(), all.radius());
  const Batch sel = selection_batch(s, lateral, glm::dvec3(0));
  EXPECT_FALSE(sel.empty());
  EXPECT_TRUE(selection_batch(s, NodeId(999u), glm::dvec3(0)).empty());
}

// ---- camera and picking ---------------------------------------------------------------

TEST(ViewerCamera, FrameAllKeepsBoundsInView) {
  Bounds b;
  b.add({-1, -2, 0});
  b.add({3, 1, 9});
  for (double yaw : {0.0, 1.0, 2.5}) {
    for (double pitch : {-0.5, 0.2, 1.2}) {
      for (double aspect : {0.5, 1.0, 2.0}) {
        OrbitCamera cam;
        cam.yaw = yaw;
        cam.pitch = pitch;
        cam.frame(b, aspect);
        const int w = static_cast<int>(400 * aspect), h = 400;
        const glm::mat4 vp = cam.projection(aspect, b.radius()) * cam.view();
        for (int c = 0; c < 8; ++c) {
          const glm::dvec3 p(c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z);
          const auto px = project_to_pixels(p, vp, w, h);
          ASSERT_TRUE(px);
          EXPECT_GE(px->x, -1.0);
          EXPECT_LE(px->x, w + 1.0);
          EXPECT_GE(px->y, -1.0);
          EXPECT_LE(px->y, h + 1.0);
        }
      }
    }
  }
}

TEST(ViewerCamera, RotatePanZoom) {
  OrbitCamera cam;
  cam.distance = 10;
  const double yaw = cam.yaw;
  cam.rotate(100, 0, 500);
  EXPECT_NE(cam.yaw, yaw);
  cam.rotate(0, 1e6, 500);
  EXPECT_LT(cam.pitch, std::numbers::pi / 2);
  const glm::dvec3 eye = cam.eye();
  EXPECT_NEAR(glm::length(eye - cam.target), 10.0, 1e-9);
  const glm::dvec3 target = cam.target;
  const glm::dvec3 forward = glm::normalize(cam.target - cam.eye());
  cam.pan(50, -20, 500);
  EXPECT_GT(glm::length(cam.target - target), 0.0);
  EXPECT_NEAR(glm::dot(cam.target - target, forward), 0.0, 1e-9);  // in the view plane
  cam.zoom(2);
  EXPECT_NEAR(cam.distance, 10 * 0.85 * 0.85, 1e-9);
  cam.up = UpAxis::y;
  EXPECT_GT(glm::dot(cam.eye() - cam.target, glm::dvec3(0, 1, 0)), -1e-12);
}

TEST(ViewerCamera, PickNodeUnderMouse) {
  const Skeleton s = built(test::y_fork());
  const Scene scene = build_scene({.skeleton = &s});
  OrbitCamera cam;
  cam.frame(scene.bounds, 1.5);
  const int w = 600, h = 400;
  const glm::mat4 vp = cam.projection(1.5, scene.bounds.radius()) * cam.view();
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto px = project_to_pixels(s.position[i] - scene.origin, vp, w, h);
    ASSERT_TRUE(px);
    const auto picked = pick_node(s, scene.origin, vp, {px->x, px->y}, w, h, 2.0);
    ASSERT_TRUE(picked);
    // Either the node itself or one drawn at the same pixel.
    const auto pp = project_to_pixels(s.position[picked->idx()] - scene.origin, vp, w, h);
    EXPECT_LT(glm::length(glm::dvec2(pp->x - px->x, pp->y - px->y)), 1.0);
  }
  EXPECT_FALSE(pick_node(s, scene.origin, vp, {-500, -500}, w, h));
}

// ---- renderer and mock backend --------------------------------------------------------

TEST(ViewerRenderer, DrawsOnlyVisibleLayersAndReleasesOldBatches) {
  const Skeleton s = built(test::y_fork());
  const Mesh m = unit_box();
  MockBackend mock;
  {
    Renderer r(mock);
    r.set_scene(build_scene({.skeleton = &s, .mesh = &m}));
    RenderOptions ro;
    ro.visible[li(Layer::skeleton)] = true;
    r.draw(100, 80, glm::mat4(1), glm::mat4(1), ro);
    EXPECT_EQ(mock.frames, 1u);
    EXPECT_EQ(mock.width, 100);
    EXPECT_GT(mock.drawn_vertices("skeleton"), 0u);
    EXPECT_EQ(mock.drawn_vertices("mesh"), 0u);
    // Hidden layers are not even uploaded.
    for (const auto& d : mock.draws) EXPECT_EQ(d.label.find("disc"), std::string::npos);
    const std::size_t uploaded = mock.uploads;
    ro.visible[li(Layer::mesh)] = true;
    ro.visible[li(Layer::wireframe)] = true;
    r.draw(100, 80, glm::mat4(1), glm::mat4(1), ro);
    ASSERT_FALSE(mock.draws.empty());
    EXPECT_EQ(mock.draws.front().primitive, Primitive::triangles);  // the opaque mesh first
    EXPECT_FALSE(mock.draws.front().params.depth_bias);
    EXPECT_TRUE(mock.draws.back().params.depth_bias);  // lines over the mesh
    EXPECT_GT(mock.uploads, uploaded);
    // Drawing again uploads nothing new.
    const std::size_t again = mock.uploads;
    r.draw(100, 80, glm::mat4(1), glm::mat4(1), ro);
    EXPECT_EQ(mock.uploads, again);
    // A new scene releases every old batch.
    const std::size_t live_before = mock.live();
    r.set_scene(build_scene({.mesh = &m}));
    EXPECT_EQ(mock.releases, live_before);
    EXPECT_EQ(mock.live(), 0u);
    r.set_overlay(selection_batch(s, NodeId(1u), glm::dvec3(0)));
    r.draw(100, 80, glm::mat4(1), glm::mat4(1), ro);
    ASSERT_FALSE(mock.draws.empty());
    EXPECT_TRUE(mock.draws.back().params.on_top);
  }
  EXPECT_EQ(mock.live(), 0u);  // the renderer releases everything when it goes
  const Image img = mock.read_pixels();
  EXPECT_EQ(img.rgba.size(), 100u * 80u * 4u);
}

// ---- images ---------------------------------------------------------------------------

TEST(ViewerImage, PngRoundTripAndFlip) {
  Image img;
  img.width = 5;
  img.height = 3;
  img.rgba.resize(5 * 3 * 4);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = static_cast<std::uint8_t>(i * 7);
  for (std::size_t i = 3; i < img.rgba.size(); i += 4) img.rgba[i] = 255;
  const auto dir = temp_dir("viewer_png");
  write_png(dir / "a.png", img);
  const Image back = read_png(dir / "a.png");
  EXPECT_EQ(back.width, 5);
  EXPECT_EQ(back.height, 3);
  EXPECT_EQ(back.rgba, img.rgba);
  Image flipped = img;
  flip_rows(flipped);
  EXPECT_TRUE(std::equal(flipped.rgba.begin(), flipped.rgba.begin() + 20, img.rgba.begin() + 40));
  EXPECT_GT(distinct_colors(img), 1u);
  EXPECT_THROW(encode_png(Image{}), InvalidInputError);
}

// ---- parameter table ------------------------------------------------------------------

TEST(ViewerParams, TableCoversEveryConfigKey) {
  // Every key params_to_json writes for a stage has exactly one field (the repair section's in
  // the meshing panel), and editing a field changes that key and no other section.
  PipelineParams p;
  const auto base = nlohmann::json::parse(params_to_json(p));
  for (Stage s : kStages) {
    const auto fields = param_fields(p, s);
    const auto& section = base.at(stage_name(s));
    std::set<std::string> keys;
    for (const auto& f : fields) keys.insert(f.key);
    EXPECT_EQ(keys.size(), fields.size()) << stage_name(s) << ": duplicate keys";
    for (const auto& [k, v] : section.items()) EXPECT_TRUE(keys.count(k)) << stage_name(s) << "." << k;
    if (s == Stage::meshing) {
      for (const auto& [k, v] : base.at("repair").items()) EXPECT_TRUE(keys.count("repair." + k)) << "repair." << k;
    }
    for (const auto& f : fields) {
      PipelineParams q;
      auto qf = param_fields(q, s);
      const auto it = std::find_if(qf.begin(), qf.end(), [&](const ParamField& x) { return x.key == f.key; });
      ASSERT_NE(it, qf.end());
      const double old = field_value(*it);
      // (0.6 is the fixed point of old * 0.5 + 0.3: repair.collar_blend's default.)
      set_field_value(*it, old == 0 ? 1 : (old == 1 ? 0 : (old == 0.6 ? 0.5 : old * 0.5 + 0.3)));
      EXPECT_NE(field_value(*it), old) << f.key;
      const auto changed = nlohmann::json::parse(params_to_json(q));
      for (Stage t : kStages) {
        if (t != s) {
          EXPECT_EQ(changed.at(stage_name(t)), base.at(stage_name(t))) << f.key;
        } else if (section.contains(f.key)) {
          EXPECT_NE(changed.at(stage_name(t)).at(f.key), section.at(f.key)) << f.key;
        }
      }
      EXPECT_EQ(first_changed_stage(PipelineParams{}, q), s) << f.key;
      EXPECT_GE(f.max, f.min);
      EXPECT_FALSE(f.help.empty());
    }
  }
  EXPECT_FALSE(first_changed_stage(PipelineParams{}, PipelineParams{}));
}

TEST(ViewerParams, FieldsComeFromTheStageTables) {
  // Key, help, unit, accepted range, slider and widget kind are the stage table's.
  PipelineParams p;
  const auto find = [](std::vector<ParamField>& fields, const std::string& key) {
    const auto it = std::find_if(fields.begin(), fields.end(), [&](const ParamField& f) { return f.key == key; });
    if (it == fields.end()) throw std::runtime_error("no field " + key);
    return *it;
  };
  auto contours = param_fields(p, Stage::contours);
  const ParamField step = find(contours, "slice_step");
  EXPECT_EQ(step.kind, ParamKind::real);
  EXPECT_NE(step.help.find("(x local radius); accepted: > 0"), std::string::npos) << step.help;
  EXPECT_DOUBLE_EQ(step.min, 0.05);
  EXPECT_DOUBLE_EQ(step.max, 2);
  set_field_value(step, 0.25);
  EXPECT_DOUBLE_EQ(p.contours.slice_step, 0.25);
  EXPECT_EQ(find(contours, "split_nested_laterals").kind, ParamKind::flag);
  EXPECT_EQ(find(contours, "max_slices_per_edge").kind, ParamKind::integer);
  auto skeleton = param_fields(p, Stage::skeleton);
  const ParamField policy = find(skeleton, "thick_child_policy");
  EXPECT_EQ(policy.kind, ParamKind::choice);
  EXPECT_EQ(policy.choices, (std::vector<std::string>{"clamp_child", "raise_parent", "keep"}));
  set_field_value(policy, 0);
  EXPECT_EQ(p.skeleton.thick_child_policy, ThickChildPolicy::clamp_child);
  // A range without a slider of its own: the slider spans it.
  auto strands = param_fields(p, Stage::strands);
  EXPECT_DOUBLE_EQ(find(strands, "alpha").max, 1);
  auto meshing = param_fields(p, Stage::meshing);
  set_field_value(find(meshing, "repair.self_union"), 0);
  EXPECT_FALSE(p.repair.self_union);
  EXPECT_EQ(first_changed_stage(PipelineParams{}, p), Stage::skeleton);
  p.skeleton = {};
  EXPECT_EQ(first_changed_stage(PipelineParams{}, p), Stage::contours);
  p.contours = {};
  EXPECT_EQ(first_changed_stage(PipelineParams{}, p), Stage::meshing);
}

TEST(ViewerParams, SetFieldClampsIntegers) {
  PipelineParams p;
  auto fields = param_fields(p, Stage::particles);
  auto it = std::find_if(fields.begin(), fields.end(), [](const ParamField& f) { return f.key == "max_steps"; });
  ASSERT_NE(it, fields.end());
  set_field_value(*it, -5);
  EXPECT_EQ(p.particles.max_steps, 0u);
  set_field_value(*it, 12.6);
  EXPECT_EQ(p.particles.max_steps, 13u);
}

// ---- node panel data ------------------------------------------------------------------

TEST(ViewerNode, CloudOfSelectedNode) {
  const TinyRun t = tiny_run();
  const NodeCloud c = node_cloud(t.skeleton, t.field, NodeId(0u), StrandColoring::by_strand, 12.0);
  EXPECT_EQ(c.particles, 3u);
  EXPECT_EQ(c.steps, 7u);
  EXPECT_EQ(c.new_strands, 1u);
  EXPECT_EQ(c.from_main, 2u);
  EXPECT_EQ(c.points.size(), 3u);
  EXPECT_EQ(c.strands[2], StrandId(2u));
  // Three points not on a line: the boundary holds all of them, counter-clockwise.
  ASSERT_EQ(c.boundary.size(), 3u);
  double area = 0;
  for (std::size_t i = 0; i < 3; ++i) area += cross2(c.points[c.boundary[i]], c.points[c.boundary[(i + 1) % 3]]);
  EXPECT_GT(area, 0);
  EXPECT_EQ(c.colors[0], particle_color(t.field, 0, StrandColoring::by_strand));
  const auto lines = node_summary(t.skeleton, c);
  EXPECT_TRUE(std::any_of(lines.begin(), lines.end(),
                          [](const std::string& l) { return l.find("relaxation steps 7") != std::string::npos; }));
  EXPECT_THROW(node_cloud(t.skeleton, t.field, NodeId(5u), StrandColoring::by_strand, 12.0), InvalidInputError);
}

// ---- background job -------------------------------------------------------------------

TEST(ViewerJob, ReportsOutcomeErrorsAndCancellation) {
  Job job;
  job.start(JobOutcome::Kind::checks, [](const ProgressFn& progress) {
    progress("working", 0.5);
    JobOutcome out;
    out.check = MeshCheckReport{};
    return out;
  });
  job.wait();
  auto out = job.take();
  ASSERT_TRUE(out);
  EXPECT_TRUE(out->error.empty());
  EXPECT_TRUE(out->check);
  EXPECT_EQ(out->kind, JobOutcome::Kind::checks);
  EXPECT_FALSE(job.busy());

  job.start(JobOutcome::Kind::load, [](const ProgressFn&) -> JobOutcome { throw InvalidInputError("bad tree"); });
  job.wait();
  out = job.take();
  ASSERT_TRUE(out);
  EXPECT_EQ(out->error, "bad tree");

  // A job that reports progress forever stops when cancelled.
  std::atomic<bool> started{false};
  job.start(JobOutcome::Kind::rerun, [&](const ProgressFn& progress) -> JobOutcome {
    for (;;) {
      started = true;
      progress("spin", 0.0);
      std::this_thread::yield();
    }
  });
  while (!started) std::this_thread::yield();
  EXPECT_TRUE(job.busy());
  job.cancel();
  job.wait();
  out = job.take();
  ASSERT_TRUE(out);
  EXPECT_TRUE(out->cancelled);
}

// ---- runs, dumps, the app -------------------------------------------------------------

std::filesystem::path write_y_fork(const std::filesystem::path& dir) {
  const auto path = dir / "y_fork.json";
  write_file_atomically(path, raw_skeleton_to_json(test::y_fork()));
  return path;
}

TEST(ViewerRun, ClassifiesInputs) {
  const auto dir = temp_dir("viewer_classify");
  const auto skel = write_y_fork(dir);
  EXPECT_EQ(classify_input(skel), InputKind::skeleton);
  EXPECT_EQ(classify_input(dir), InputKind::stage_dump);
  write_mesh(unit_box(), dir / "box.obj");
  EXPECT_EQ(classify_input(dir / "box.obj"), InputKind::mesh);
  EXPECT_THROW(classify_input(dir / "missing.json"), IoError);
}

TEST(ViewerRun, StageDumpRoundTrip) {
  // A run dumped by dump_stages and read back shows the same stages: same particles, same
  // loops, and the mesh rebuilt from the dumped contours equals the run's mesh.
  const auto dir = temp_dir("viewer_dump");
  const RawSkeleton raw = test::y_fork();
  const PipelineParams params;
  const PipelineResult r = run_pipeline(raw, params);
  dump_stages(r, dir / "dump");
  const RunData d = load_stage_dump(dir / "dump", params);
  EXPECT_TRUE(d.has_stage(Stage::skeleton));
  EXPECT_TRUE(d.has_stage(Stage::particles));
  EXPECT_TRUE(d.has_stage(Stage::strands));
  EXPECT_TRUE(d.has_stage(Stage::contours));
  EXPECT_TRUE(d.has_stage(Stage::meshing));
  EXPECT_TRUE(d.can_rerun());
  EXPECT_EQ(d.result.skeleton.skeleton.size(), r.skeleton.skeleton.size());
  EXPECT_EQ(d.result.particles.position, r.particles.position);
  ASSERT_EQ(d.result.contours.loop_count(), r.contours.loop_count());
  EXPECT_EQ(d.result.contours.point, r.contours.point);
  EXPECT_EQ(d.result.contours.junctions.size(), r.contours.junctions.size());
  for (std::size_t l = 0; l < r.contours.loop_count(); ++l) {
    EXPECT_LT(glm::length(d.result.contours.loop_frame[l].tangent - r.contours.loop_frame[l].tangent), 1e-9);
  }
  EXPECT_EQ(d.result.mesh.mesh.triangles, r.mesh.mesh.triangles);
  // A mesh file in the directory is preferred over rebuilding.
  write_mesh(unit_box(), dir / "dump" / "other.obj");
  const RunData e = load_stage_dump(dir / "dump", params);
  EXPECT_EQ(e.result.mesh.mesh.triangle_count(), 12u);
  EXPECT_NE(e.note.find("other.obj"), std::string::npos);
  // Not a dump.
  EXPECT_THROW(load_stage_dump(dir, params), InvalidInputError);
  EXPECT_THROW(contours_from_json("{\"loops\": [{\"node\": 99}]}", r.skeleton.skeleton, "c.json"), InvalidInputError);
  EXPECT_THROW(contours_from_json("not json", r.skeleton.skeleton, "c.json"), InvalidInputError);
}

TEST(ViewerRun, MeshFileAlone) {
  const auto dir = temp_dir("viewer_meshfile");
  write_mesh(unit_box(), dir / "box.ply");
  const RunData d = load_input(dir / "box.ply", {});
  EXPECT_TRUE(d.has_stage(Stage::meshing));
  EXPECT_FALSE(d.has_stage(Stage::skeleton));
  EXPECT_FALSE(d.can_rerun());
  const StageView v = view_of(d);
  EXPECT_EQ(v.skeleton, nullptr);
  ASSERT_NE(v.mesh, nullptr);
  EXPECT_EQ(v.mesh->triangle_count(), 12u);
  const MeshCheckReport c = run_checks(d);
  EXPECT_TRUE(c.closed);
  EXPECT_EQ(c.genus, 0);
}

// Options for opening `input`; designated initializers would leave the path members
// unnamed, which -Wextra flags.
ViewerOptions options_for(const std::filesystem::path& input, bool checks = true, bool self_intersections = true) {
  ViewerOptions o;
  o.input = input;
  o.checks = checks;
  o.self_intersections = self_intersections;
  return o;
}

class ViewerAppTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = temp_dir(std::string("viewer_app_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    skeleton_ = write_y_fork(dir_);
  }
  std::filesystem::path dir_, skeleton_;
};

TEST_F(ViewerAppTest, LoadsRendersSelectsAndReruns) {
  ViewerApp app(options_for(skeleton_, true, false));
  app.start();
  app.wait_idle();
  ASSERT_NE(app.run(), nullptr) << app.error();
  EXPECT_TRUE(app.error().empty()) << app.error();
  for (Stage s : kStages) EXPECT_TRUE(app.run()->has_stage(s)) << stage_name(s);
  ASSERT_TRUE(app.check());  // checks ran after the load
  EXPECT_TRUE(app.check()->closed);
  // Default view: mesh and skeleton.
  EXPECT_TRUE(app.view().visible[li(Layer::mesh)]);
  MockBackend mock;
  Renderer renderer(mock);
  app.render(renderer, 640, 480);
  EXPECT_GT(mock.drawn_vertices("mesh"), 0u);
  EXPECT_GT(mock.drawn_vertices("skeleton"), 0u);
  EXPECT_EQ(mock.drawn_vertices("strands"), 0u);
  app.set_layer_visible(Layer::strands, true);
  app.set_layer_visible(Layer::contours, true);
  app.render(renderer, 640, 480);
  EXPECT_GT(mock.drawn_vertices("strands"), 0u);
  EXPECT_GT(mock.drawn_vertices("split"), 0u);  // the y fork has one split
  // Recolouring rebuilds the strand layer only.
  const std::size_t uploads = mock.uploads;
  app.set_coloring(StrandColoring::by_tip);
  app.render(renderer, 640, 480);
  EXPECT_EQ(mock.uploads - uploads,
            renderer.scene().layer(Layer::strands).size() + (app.view().visible[li(Layer::particles)] ? 1u : 0u));

  // Click on the fork node: it gets selected and the node panel's cloud is computed.
  const Skeleton& s = app.run()->result.skeleton.skeleton;
  std::size_t fork = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.is_fork(NodeId(i))) fork = i;
  }
  const glm::mat4 vp = app.projection_matrix(640, 480) * app.view_matrix();
  const auto px = project_to_pixels(s.position[fork] - app.scene_origin(), vp, 640, 480);
  ASSERT_TRUE(px);
  app.on_click(px->x, px->y, 640, 480);
  ASSERT_TRUE(app.selection());
  ASSERT_NE(app.selected_cloud(), nullptr);
  EXPECT_EQ(app.selected_cloud()->particles, app.run()->result.particles.count(*app.selection()));
  EXPECT_TRUE(app.frame_selection(640.0 / 480.0));
  app.on_click(-1000, -1000, 640, 480);
  EXPECT_FALSE(app.selection());

  // Editing a contour parameter re-runs from the contours stage on.
  const std::size_t loops = app.run()->result.contours.loop_count();
  app.edited_params().contours.resolution = 2;
  app.edited_params().contours.min_slice_step = 0.1;
  EXPECT_EQ(app.apply_changes(), Stage::contours);
  app.wait_idle();
  EXPECT_TRUE(app.error().empty()) << app.error();
  EXPECT_GT(app.run()->result.contours.loop_count(), loops);
  EXPECT_EQ(app.applied_params().contours.resolution, 2);
  EXPECT_FALSE(app.apply_changes());  // nothing left to apply

  // A failing re-run shows its error and keeps the previous run.
  const RunData* before = app.run();
  app.edited_params().particles.min_particles = 1;
  app.request_rerun(Stage::particles);
  app.wait_idle();
  EXPECT_NE(app.error().find("failed"), std::string::npos);
  EXPECT_EQ(app.run(), before);
}

TEST_F(ViewerAppTest, ProblemsLayerShowsTheChecksOnceTheyRan) {
  write_mesh(box_with_stray_triangle(), dir_ / "bad.ply");
  MockBackend mock;
  Renderer renderer(mock);
  {
    ViewerApp app(options_for(dir_ / "bad.ply", false));
    app.start();
    app.wait_idle();
    ASSERT_NE(app.run(), nullptr) << app.error();
    EXPECT_TRUE(app.view().visible[li(Layer::problems)]);  // on by default with a mesh
    app.render(renderer, 320, 240);
    EXPECT_EQ(mock.drawn_vertices("self-intersecting"), 0u);  // checks off: nothing to show
  }
  ViewerApp app(options_for(dir_ / "bad.ply"));
  app.start();
  app.wait_idle();
  ASSERT_TRUE(app.check());
  app.render(renderer, 320, 240);
  EXPECT_GT(mock.drawn_vertices("self-intersecting"), 0u);
  EXPECT_EQ(mock.drawn_vertices("boundary"), 3u * 2);
  app.set_layer_visible(Layer::problems, false);
  app.render(renderer, 320, 240);
  EXPECT_EQ(mock.drawn_vertices("boundary"), 0u);
}

TEST_F(ViewerAppTest, BadInputsShowErrorsInsteadOfCrashing) {
  const auto bad = dir_ / "bad.json";
  write_file_atomically(bad, "{\"nodes\": [{\"id\": 0, \"parent\": -1, \"position\": [0, 0, 0], \"radius\": -1}]}");
  ViewerApp app(options_for(bad));
  app.start();
  app.wait_idle();
  EXPECT_EQ(app.run(), nullptr);
  EXPECT_NE(app.error().find("loading failed"), std::string::npos);
  MockBackend mock;
  Renderer renderer(mock);
  app.render(renderer, 64, 64);  // draws an empty frame
  EXPECT_EQ(mock.frames, 1u);
  app.request_rerun(Stage::particles);  // nothing loaded: an error, not a crash
  EXPECT_FALSE(app.error().empty());

  const auto config = dir_ / "config.json";
  write_file_atomically(config, "{\"particles\": {\"no_such_key\": 1}}");
  ViewerOptions with_config = options_for(skeleton_, false);
  with_config.config = config;
  ViewerApp app2(with_config);
  app2.start();
  app2.wait_idle();
  ASSERT_NE(app2.run(), nullptr);  // runs with the defaults
  EXPECT_NE(app2.error().find("no_such_key"), std::string::npos);
}

TEST_F(ViewerAppTest, CameraSpecFramesNode) {
  ViewerApp app(options_for(skeleton_, false));
  app.start();
  app.wait_idle();
  ASSERT_NE(app.run(), nullptr);
  app.apply_camera_spec(parse_camera_spec("yaw=90,pitch=0,dist=2"), 1.0);
  EXPECT_NEAR(app.camera().yaw, std::numbers::pi / 2, 1e-12);
  const double d_all = app.camera().distance;
  app.apply_camera_spec(parse_camera_spec("node=3"), 1.0);
  EXPECT_LT(app.camera().distance, d_all);
  const double d_subtree = app.camera().distance;
  app.apply_camera_spec(parse_camera_spec("node=3,around=2"), 1.0);
  EXPECT_LT(app.camera().distance, d_subtree);
  const Skeleton& s = app.run()->result.skeleton.skeleton;
  EXPECT_LT(glm::length(app.camera().target - (s.position[3] - app.scene_origin())), 1e-9);
  EXPECT_THROW(app.apply_camera_spec(parse_camera_spec("around=2"), 1.0), UsageError);
  EXPECT_THROW(app.apply_camera_spec(parse_camera_spec("node=100000"), 1.0), UsageError);
}

// ---- panels, headless ------------------------------------------------------------------

class ImGuiHeadless : public ViewerAppTest {
 protected:
  void SetUp() override {
    ViewerAppTest::SetUp();
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(1280, 800);
    io.DeltaTime = 1.0f / 60.0f;
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);  // builds the font atlas; no GPU needed
  }
  void TearDown() override { ImGui::DestroyContext(); }

  // Lays out and tessellates one frame; returns the number of vertices ImGui produced.
  int frame(ViewerApp& app, PanelState& state) {
    ImGui::NewFrame();
    draw_panels(app, state, 1280, 800);
    ImGui::Render();
    return ImGui::GetDrawData()->TotalVtxCount;
  }
};

TEST_F(ImGuiHeadless, PanelsDrawForEveryState) {
  ViewerApp app(options_for(skeleton_, true, false));
  PanelState state;
  EXPECT_GT(frame(app, state), 0);  // before anything is loaded
  app.start();
  frame(app, state);  // while loading
  app.wait_idle();
  ASSERT_NE(app.run(), nullptr);
  for (int i = 0; i < 3; ++i) EXPECT_GT(frame(app, state), 0);
  EXPECT_NE(ImGui::FindWindowByName("Stages"), nullptr);
  EXPECT_NE(ImGui::FindWindowByName("Status"), nullptr);
  EXPECT_EQ(ImGui::FindWindowByName("Node"), nullptr);  // nothing selected yet
  app.select(NodeId(2u));
  frame(app, state);
  ImGuiWindow* node = ImGui::FindWindowByName("Node");
  ASSERT_NE(node, nullptr);
  EXPECT_TRUE(node->Active);
  // The node panel draws one filled circle per particle: its draw list grows with them.
  EXPECT_GT(node->DrawList->VtxBuffer.Size, static_cast<int>(app.selected_cloud()->particles) * 12);
  // An error is shown, not thrown.
  app.edited_params().particles.min_particles = 1;
  app.request_rerun(Stage::particles);
  app.wait_idle();
  EXPECT_GT(frame(app, state), 0);
  EXPECT_FALSE(app.error().empty());
  // Legend alone, as in screenshots.
  ImGui::NewFrame();
  draw_legend(app, 10.0f, 800);
  ImGui::Render();
  EXPECT_NE(ImGui::FindWindowByName("Legend"), nullptr);
}

}  // namespace
}  // namespace sm::viewer
