#include "settings.hpp"

#include <limits>

namespace talus::block_gen {

core::Range block_volume_range() { return core::Range::closed(block::kMinVolume, block::kMaxVolume); }
core::Range density_range() { return core::Range::closed(100.0, 1e5); }

void RepairSettings::visit(core::SettingsVisitor& v) {
  v.field("orient", orient, "make face orientation consistent and outward (reported)");
  v.field("stitch", stitch, "merge vertices closer than stitch_tolerance, closing cracks (reported)");
  v.bounded("stitch_tolerance", stitch_tolerance, "m", "stitch distance; 0 = 1e-6 x bounding-box diagonal",
            core::Range::closed(0.0, 1e3));
  v.field("fill_holes", fill_holes, "close holes of up to max_hole_edges boundary edges (reported)");
  v.bounded("max_hole_edges", max_hole_edges, "-", "largest hole filled, in boundary edges",
            core::Range{3.0, std::numeric_limits<double>::infinity()});
}

void SimplifySettings::visit(core::SettingsVisitor& v) {
  v.choice("mode", mode, {"none", "faces", "hull"},
           "level of detail: none, faces (edge collapse to target_faces triangles) or hull (convex hull)");
  v.bounded("target_faces", target_faces, "-", "triangle count after simplification (mode: faces)",
            core::Range::closed(4.0, 1e8));
}

void InputSettings::visit(core::SettingsVisitor& v) {
  v.bounded("scale", scale, "-", "multiplies file coordinates, e.g. 0.001 for a file in mm",
            core::Range::positive(1e6));
  v.choice("up_axis", up_axis, {"z", "y"}, "up axis of the file; y-up files are rotated to z-up");
  v.choice("reconstruction", reconstruction, {"hull", "advancing_front"},
           "point clouds: convex hull, or concave advancing-front reconstruction");
  // The ranges the reconstruction and repair accept, declared so that the reader names a
  // value out of them by its line or --set key (not the mesh or cloud file).
  v.bounded("radius_ratio_bound", radius_ratio_bound, "-",
            "advancing front: refuse triangles whose circumradius exceeds this multiple of their shortest edge "
            "(larger bridges wider gaps)",
            core::Range{0.0, std::numeric_limits<double>::infinity(), true, false});
  v.bounded("beta_deg", beta_deg, "deg", "advancing front: sharpest dihedral angle change the surface may follow",
            core::Range{0.0, 180.0, true, true});
  v.section("repair", "repairs of defective meshes, only when asked, always reported",
            [this](core::SettingsVisitor& s) { repair.visit(s); });
  v.section("simplify", "level of detail; the changes in volume, inertia and sphericity are reported",
            [this](core::SettingsVisitor& s) { simplify.visit(s); });
}

void BlockSettings::visit(core::SettingsVisitor& v) {
  v.field("name", name, "block name, unique in the file (default: the solid name or the file stem)");
  v.choice("solid", solid,
           {"none", "tetrahedron", "cube", "octahedron", "dodecahedron", "icosahedron", "box", "ellipsoid", "rock"},
           "named solid (none when the block comes from mesh or cloud)");
  v.field("mesh", mesh, "mesh file (OBJ, STL, PLY, OFF, glTF ...), relative to the working directory");
  v.field("cloud", cloud, "point cloud file (.xyz/.txt/.pts/.csv, .las or PLY)");
  v.bounded("volume", volume, "m^3",
            "target volume: solids are scaled to it (default 1 for Platonic solids and rocks); a mesh or cloud is "
            "scaled about its centroid only when given",
            block_volume_range());
  // No default shape: a box or an ellipsoid whose dimensions were forgotten is refused,
  // not built as a 1 m cube or sphere.
  v.bounded("dimensions", dimensions, "m",
            "box edges, or ellipsoid diameters, along x, y, z (required for box and ellipsoid; 0 0 0 = not given)",
            core::Range::closed(0.0, 1e3));
  // The ranges block::make_solid accepts, declared here so that a value out of them is
  // named by its line or --set key.
  v.bounded("resolution", resolution, "-", "ellipsoid: geodesic frequency n (20 n^2 triangles)",
            core::Range::closed(1.0, 1000.0));
  v.bounded("roughness", roughness, "-",
            "ellipsoid: sd of the relative height of 40 random smooth bumps and dents; > 0 makes a concave rock",
            core::Range::closed(0.0, 0.3));
  v.bounded("elongation", elongation, "-", "rock: target L2/L1 along the principal axes", core::Range::positive(1.0));
  v.bounded("flatness", flatness, "-", "rock: target L3/L2 along the principal axes", core::Range::positive(1.0));
  v.bounded("points", points, "-", "rock: number of random points whose convex hull is the rock",
            core::Range::closed(8.0, 100000.0));
  v.field("seed", seed, "-", "rock, rough ellipsoid: seed of the block_shape random stream");
  v.bounded("density", density, "kg/m^3", "density of this block (default: the top-level density)",
            density_range());
  v.bounded("weight", weight, "-", "relative probability of this block when a run samples the library",
            core::Range::closed(0.0, 1e12));
  v.section("input", "how the mesh or cloud file is read, repaired and simplified",
            [this](core::SettingsVisitor& s) { input.visit(s); });
}

void Settings::visit(core::SettingsVisitor& v) {
  v.bounded("density", density, "kg/m^3", "rock density of every block without its own", density_range());
  v.field("xdmf", xdmf, "write a .xmf sidecar next to the output so ParaView shows the blocks");
  v.section("inputs", "how the INPUT files named on the command line are read",
            [this](core::SettingsVisitor& s) { inputs.visit(s); });
  v.list_of("blocks", "the blocks of the library, in order", blocks);
}

}  // namespace talus::block_gen
