/// @file rope_readings.cpp
/// @brief Tensions and bending moments off a state (rope_readings.hpp).
#include "constrained_particles/core/rope_readings.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace constrained_particles
{
std::vector<LinkTension> linkTensions(const Model& model, const Points& positions,
                                      const Eigen::VectorXd& multipliers)
{
  if (multipliers.size() < model.numRows())
    throw std::invalid_argument("linkTensions: " + std::to_string(multipliers.size()) +
                                " multipliers for " + std::to_string(model.numRows()) + " rows");
  struct Indexed
  {
    int constraint;
    LinkTension link;
  };
  std::vector<Indexed> found;
  auto length = [&](int i, int j) { return (positions.col(i) - positions.col(j)).norm(); };
  for (const auto& entry : std::get<std::vector<KindRecord<LinkConstraint>>>(model.kindTables()))
  {
    const LinkConstraint& link = entry.record;
    found.push_back({ entry.constraint,
                      { link.first, link.second,
                        -multipliers[entry.first_row] * length(link.first, link.second) } });
  }
  for (const auto& entry : std::get<std::vector<KindRecord<SlackLink>>>(model.kindTables()))
  {
    const SlackLink& link = entry.record;
    found.push_back({ entry.constraint,
                      { link.first, link.second,
                        multipliers[entry.first_row] * length(link.first, link.second) } });
  }
  std::sort(found.begin(), found.end(),
            [](const Indexed& a, const Indexed& b) { return a.constraint < b.constraint; });
  std::vector<LinkTension> tensions;
  tensions.reserve(found.size());
  for (const Indexed& f : found)
    tensions.push_back(f.link);
  return tensions;
}

std::vector<JointMoment> bendingMoments(const Model& model, const Points& positions)
{
  std::vector<JointMoment> moments;
  for (const Force& force : model.scene().forces)
    if (const auto* joint = std::get_if<BendingForce>(&force))
      moments.push_back({ joint->middle, bendingMoment(*joint, positions) });
  return moments;
}

}  // namespace constrained_particles
