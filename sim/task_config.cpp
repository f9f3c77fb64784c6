// The scenario's `task` section: the incisions an instructor asks for and the pass thresholds
// (docs/formats.md, docs/scoring.md).
#include "sim/task_config.hpp"

namespace scalpel {

namespace {

Incision read_incision(const YamlReader& r, const YamlMap& m, const YamlValue& v) {
  Incision t;
  t.where = yaml_location(v.key_mark);
  const YamlValue vpath = m.require("path");
  const auto points = r.list(vpath, "a list of points [x, y, z]");
  if (points.size() < 2) r.fail(vpath, "expected at least 2 points");
  for (const auto& p : points) {
    t.path.push_back(r.vector<3>(p));
    if (t.path.size() > 1 && t.path[t.path.size() - 2] == t.path.back())
      r.fail(p, "repeats the previous point");
  }
  if (const auto x = m.get("tolerance")) t.tolerance = r.positive(*x, 0.1);
  const YamlValue vdepth = m.require("depth");
  const auto depth = r.vector<2>(vdepth);
  t.depth_min = depth[0];
  t.depth_max = depth[1];
  if (!(depth[0] >= 0.0 && depth[0] < depth[1] && depth[1] <= kMaxScenarioLength))
    r.fail(vdepth, "expected [min, max] with 0 <= min < max <= " + r.format(kMaxScenarioLength) + " [m]");
  return t;
}

void read_pass(const YamlReader& r, const YamlValue& v, PassThresholds& out) {
  const YamlMap m(r, v);
  m.only({"score", "coverage", "depth_in_band", "bevel_deg", "strokes", "economy", "time", "force",
          "force_in_band", "collateral"});
  const auto fraction = [&](const YamlValue& x) {
    const double f = r.number(x);
    r.check(x, f >= 0.0 && f <= 1.0, "a fraction 0 to 1");
    return f;
  };
  if (const auto x = m.get("score")) {
    out.score = r.number(*x);
    r.check(*x, out.score >= 0.0 && out.score <= 100.0, "0 to 100");
  }
  if (const auto x = m.get("coverage")) out.coverage = fraction(*x);
  if (const auto x = m.get("depth_in_band")) out.depth_in_band = fraction(*x);
  if (const auto x = m.get("bevel_deg")) out.bevel_deg = r.positive(*x, 90.0);
  if (const auto x = m.get("strokes")) out.strokes = r.in_range(*x, r.integer(*x), 1, 1000);
  if (const auto x = m.get("economy")) {
    out.economy = r.number(*x);
    r.check(*x, out.economy >= 1.0, "a ratio >= 1");
  }
  if (const auto x = m.get("time")) out.time = r.positive(*x);
  if (const auto x = m.get("force")) {
    const auto f = r.vector<2>(*x);
    if (!(f[0] >= 0.0 && f[0] < f[1])) r.fail(*x, "expected [min, max] with 0 <= min < max [N]");
    out.force_min = f[0];
    out.force_max = f[1];
  }
  if (const auto x = m.get("force_in_band")) out.force_in_band = fraction(*x);
  if (const auto x = m.get("collateral")) out.collateral = fraction(*x);
}

}  // namespace

Task read_task(const YamlReader& r, const YamlValue& v) {
  const YamlMap m(r, v);
  m.only({"path", "tolerance", "depth", "incisions", "protected", "pass", "scored"});
  Task t;
  if (const auto x = m.get("scored")) t.scored = r.boolean(*x);
  t.where = yaml_location(v.key_mark);
  if (const auto x = m.get("incisions")) {
    if (m.get("path") || m.get("tolerance") || m.get("depth"))
      r.fail(*x, "give either `incisions` or one incision's `path`, `tolerance` and `depth`, not both");
    const auto items = r.list(*x, "a list of incisions {path, tolerance, depth}");
    if (items.empty()) r.fail(*x, "expected at least one incision");
    for (const YamlValue& item : items) {
      const YamlMap im(r, item);
      im.only({"path", "tolerance", "depth"});
      t.incisions.push_back(read_incision(r, im, item));
    }
  } else {
    t.incisions.push_back(read_incision(r, m, v));
  }
  if (const auto x = m.get("protected")) {
    t.protected_where = yaml_location(x->key_mark);
    for (const YamlValue& region : r.list(*x, "a list of region names"))
      t.protected_regions.push_back(r.string(region));
  }
  if (const auto x = m.get("pass")) {
    if (!t.scored) r.fail(x->key_mark, x->path, "an unscored task (scored: false) has no pass thresholds");
    read_pass(r, *x, t.pass);
  }
  return t;
}

}  // namespace scalpel
