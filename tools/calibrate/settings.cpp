#include "settings.hpp"

namespace talus::calibrate {

void FittedParameter::visit(core::SettingsVisitor& v) {
  v.field("material", material, "name of the terrain material whose property is fitted (empty for roughness_sigma)");
  v.choice("parameter", parameter,
           {"restitution_mean", "restitution_sd", "restitution_scale", "friction_angle_mean_deg",
            "friction_coefficient_sd", "lateral_tilt_sd_deg", "ploughing", "roughness_sigma"},
           "the material property fitted (its unit: -, -, m/s, deg, -, deg, -), or the terrain's roughness_sigma (m)");
  v.choice("prior", prior, {"uniform", "normal"}, "prior: uniform on [min, max], or normal(mean, sd) truncated to it");
  v.field("min", min, "", "lower bound of the prior, in the parameter's unit");
  v.field("max", max, "", "upper bound of the prior, in the parameter's unit");
  v.field("mean", mean, "", "mean of a normal prior, in the parameter's unit");
  v.field("sd", sd, "", "standard deviation of a normal prior, in the parameter's unit");
}

void Summary::visit(core::SettingsVisitor& v) {
  v.choice("statistic", statistic, {"share_above", "quantile", "max", "min"},
           "share_above: share of the blocks above threshold; quantile: the p-quantile; max, min: the extreme of n "
           "blocks");
  v.choice("variable", variable, {"runout", "lateral", "speed", "jump"},
           "runout (m, along the runout direction from the origin), lateral (m, left positive), speed (m/s, each "
           "block's largest centroid speed) or jump (m, each block's highest centroid above the ground after its "
           "first touch)");
  v.field("threshold", threshold, "", "share_above: the value blocks above count, in the variable's unit");
  v.field("p", p, "-", "quantile: its probability, in (0, 1)");
  v.field("value", value, "", "the published value, in the variable's unit (a share: -, in [0, 1])");
  v.field("sd", sd, "", "the value's standard uncertainty (> 0), in its unit");
  v.field("count", count, "-", "share_above: the blocks above the threshold, of n (instead of value and sd)");
  v.field("n", n, "-", "max, min: the blocks the extreme is over; share_above with count: the blocks counted");
}

void Group::visit(core::SettingsVisitor& v) {
  v.field("name", name, "name of the observed case in the outputs; empty = group K");
  v.field("set", set, "scene overrides of this case, KEY=VALUE as dda-run --set (e.g. its release point)");
  v.field("observed", observed,
          "observed stops: a CSV of x, y (header x, y or easting, northing), a CSV of runout[, lateral] (m), or a "
          "vector file of points, in the terrain's input coordinates");
  v.list_of("summaries", "published summary statistics of the case, each with its uncertainty (instead of observed)",
            summaries);
  v.field("layer", layer, "layer of a vector file; empty = its only layer");
  v.field("origin", origin, "m", "[x, y] runout is measured from (terrain input coordinates); empty = the scene's "
                                 "first release point");
  v.bounded("main_direction_deg", main_direction_deg, "deg",
            "azimuth of the runout direction from +x, counter-clockwise; empty = the scene's release.main_direction_deg",
            core::Range::symmetric(360.0));
}

void Settings::visit(core::SettingsVisitor& v) {
  v.field("scene", scene, "the dda-run scene file simulated (paths in it are relative to the working directory)");
  v.field("set", set, "scene overrides for every group, KEY=VALUE as dda-run --set");
  v.list_of("groups", "observed cases, each simulated with its own scene overrides", groups);
  v.list_of("parameters", "fitted material properties and their priors", parameters);
  v.choice("variables", variables, {"runout_lateral", "runout", "distance"},
           "compared: stop points in plan (runout and lateral offset, m), runout alone (m) or the horizontal "
           "distance from the group's origin (m)");
  v.choice("unstopped", unstopped, {"count", "drop"},
           "simulated blocks not at rest: count them where they ended (one that left the terrain at its exit, a "
           "lower bound of its runout) or drop them from the comparison");
  v.field("realizations", realizations, "", "realizations per simulation and group");
  v.field("particles", particles, "", "particles of each generation (ABC population)");
  v.field("generations", generations, "", "generations after the prior's, at most");
  v.field("quantile", quantile, "-", "tolerance of a generation: this quantile of the previous one's distances");
  v.field("min_acceptance", min_acceptance, "-", "stop once a generation accepts fewer of its proposals than this");
  v.field("max_simulations", max_simulations, "",
          "parameter sets simulated at most (0 = no limit; otherwise at least 2 x particles)");
  v.field("seed", seed, "", "seed of the proposals and of every simulation");
  v.field("predictive_draws", predictive_draws, "", "posterior draws simulated by --predict");
  v.field("plots", plots, "draw plots with the talus-plot helper (Python 3, matplotlib, h5py)");
}

}  // namespace talus::calibrate
