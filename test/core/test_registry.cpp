// Typed tests over the registries: every constraint kind's Jacobian and Jdot v against central
// finite differences, every eliminated kind's imposed motion against the derivatives of its
// position, every force kind against the gradient of its potential. Records are generated from
// each kind's field descriptors, so a new kind is checked here without a new test.
#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/forces.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <type_traits>

using namespace constrained_particles;
using constrained_particles::testing::evaluateRecord;
using constrained_particles::testing::Random;

namespace
{
constexpr int PARTICLES = 5;  // particles of the random scenes
constexpr int TRIALS = 60;
constexpr double STEP = 1e-6;  // central differences [m], [s]

template <typename Variant>
struct AsTypes;
template <typename... Kinds>
struct AsTypes<std::variant<Kinds...>>
{
  using type = ::testing::Types<Kinds...>;
};

// the constraint kinds whose ELIMINATED is `Eliminated`, as gtest types
template <bool Eliminated, typename Picked, typename... Kinds>
struct Pick;
template <bool Eliminated, typename... Picked>
struct Pick<Eliminated, std::tuple<Picked...>>
{
  using type = ::testing::Types<Picked...>;
};
template <bool Eliminated, typename... Picked, typename Kind, typename... Rest>
struct Pick<Eliminated, std::tuple<Picked...>, Kind, Rest...>
{
  using type = typename std::conditional_t<Kind::ELIMINATED == Eliminated,
                                           Pick<Eliminated, std::tuple<Picked..., Kind>, Rest...>,
                                           Pick<Eliminated, std::tuple<Picked...>, Rest...>>::type;
};
template <bool Eliminated, typename Variant>
struct KindsOf;
template <bool Eliminated, typename... Kinds>
struct KindsOf<Eliminated, std::variant<Kinds...>>
{
  using type = typename Pick<Eliminated, std::tuple<>, Kinds...>::type;
};

struct KindName
{
  template <typename Kind>
  static std::string GetName(int)
  {
    return Kind::KIND;
  }
};

// a value inside the range, kept to O(1) so that finite differences are accurate
double sample(Random& random, const Range& range)
{
  const double low = std::max(range.low, -2.0), high = std::min(range.high, 2.0);
  return low + (high - low) * random.uniform(0.05, 0.95);
}

// A random valid record of a kind, from its fields: distinct particles, numbers and vectors in
// range, from_start fields left for fillFromStart.
template <typename Kind>
Kind randomRecord(Random& random)
{
  Kind record;
  std::vector<int> used;
  auto particle = [&]
  {
    int i;
    do
      i = static_cast<int>(random.uniform(0.0, PARTICLES - 1e-9));
    while (std::find(used.begin(), used.end(), i) != used.end());
    used.push_back(i);
    return i;
  };
  forEachField<Kind>(
      [&](const auto& spec)
      {
        auto& member = record.*(spec.member);
        using Member = std::decay_t<decltype(member)>;
        if constexpr (std::is_same_v<Member, int>)
          member = spec.kind == FieldKind::Surface ? 0 : particle();
        else if constexpr (std::is_same_v<Member, double>)
        {
          if (!spec.from_start)
            member = sample(random, *spec.range);
        }
        else if constexpr (std::is_same_v<Member, Vec3>)
        {
          if (spec.kind == FieldKind::Direction)
            member = random.unitVector();
          else if (!spec.from_start)
            member = Vec3(sample(random, *spec.range), sample(random, *spec.range),
                          sample(random, *spec.range));
        }
        else if constexpr (std::is_same_v<Member, std::string>)
        {
          // a holder's names: a frame, not a topic (exactly one is set)
          member = std::string(spec.name) == "frame" ? "holder" : "";
        }
        else if constexpr (std::is_same_v<Member, Shape>)
        {
          // any type, turned and moved, sized like the particles' spread
          member.name = "obstacle";
          member.type = static_cast<ShapeType>(static_cast<int>(random.uniform(0.0, 4.999)));
          member.position = random.vector(1.0);
          member.rotation = rotationFromRpy(random.vector(M_PI));
          member.radius = random.uniform(0.2, 1.0);
          member.length = random.uniform(0.2, 1.5);
          member.size =
              Vec3(random.uniform(0.2, 1.5), random.uniform(0.2, 1.5), random.uniform(0.2, 1.5));
        }
        else
        {
          for (int& index : member)
            index = particle();
        }
      });
  return record;
}

// the surfaces a random record may name
const std::vector<Surface>& surfaces()
{
  static const std::vector<Surface> SURFACES{ makeSurface("waves", { 0.3, 2.0, 1.5 }) };
  return SURFACES;
}

// a random state, and a record of Kind completed from it (unset fields as they start)
template <typename Kind>
Kind randomCase(Random& random, Points& p, Points& v)
{
  p.resize(3, PARTICLES);
  v.resize(3, PARTICLES);
  for (int i = 0; i < PARTICLES; ++i)
  {
    p.col(i) = random.vector(1.5);
    v.col(i) = random.vector(2.0);
  }
  Kind record = randomRecord<Kind>(random);
  if constexpr (std::is_same_v<Kind, SegmentContact>)
  {
    // a plane is refused (a segment's nearest point to it is an end): another type
    if (record.shape.type == ShapeType::Plane)
      record.shape.type = static_cast<ShapeType>(1 + static_cast<int>(random.uniform(0.0, 3.999)));
    // a segment inside a box or a cylinder has its least distance where two faces' distances
    // meet, a kink of C (segment_contact.hpp): its particles are placed again until it is outside
    auto inside = [&]
    {
      return nearestOnSegment(record.shape, fixedPose(record.shape), p.col(record.first),
                              p.col(record.second), SEGMENT_END_FRACTION,
                              1.0 - SEGMENT_END_FRACTION)
                 .sample.distance <= 0.0;
    };
    while (inside())
    {
      p.col(record.first) = random.vector(1.5);
      p.col(record.second) = random.vector(1.5);
    }
  }
  Points start = p, start_v = v;
  fillFromStart(record, surfaces(), start, start_v);
  validateConstraint(Constraint(record), PARTICLES, 1, "record");
  return record;
}

template <typename Kind>
class ConstraintKind : public ::testing::Test
{
};
TYPED_TEST_SUITE(ConstraintKind, AsTypes<Constraint>::type, KindName);

template <typename Kind>
class RowKind : public ::testing::Test
{
};
using RowKinds = KindsOf<false, Constraint>::type;
TYPED_TEST_SUITE(RowKind, RowKinds, KindName);

template <typename Kind>
class EliminatedKind : public ::testing::Test
{
};
using EliminatedKinds = KindsOf<true, Constraint>::type;
TYPED_TEST_SUITE(EliminatedKind, EliminatedKinds, KindName);

template <typename Kind>
class ForceKind : public ::testing::Test
{
};
TYPED_TEST_SUITE(ForceKind, AsTypes<Force>::type, KindName);

}  // namespace

// Row kinds: J_r = dC_r/dp and Jdot v = d/dt [J(p + t v) v] by central differences; C depends
// on positions only; the metric violation is finite and non-negative.
TYPED_TEST(RowKind, RowsMatchFiniteDifferences)
{
  using Kind = TypeParam;
  {
    Random random(100 + Constraint(Kind{}).index());
    for (int trial = 0; trial < TRIALS; ++trial)
    {
      Points p, v;
      const Kind record = randomCase<Kind>(random, p, v);
      const Points zero = Points::Zero(3, PARTICLES);
      const auto rows = evaluateRecord(record, surfaces(), p, v);
      const auto at_rest = evaluateRecord(record, surfaces(), p, zero);
      for (int r = 0; r < Kind::ROWS; ++r)
      {
        SCOPED_TRACE(std::string(Kind::KIND) + " row " + std::to_string(r) + ", trial " +
                     std::to_string(trial));
        EXPECT_EQ(rows.value[r], at_rest.value[r]);
        EXPECT_TRUE(std::isfinite(rows.violation[r]) && rows.violation[r] >= 0.0);
        // J against dC/dp
        const Points analytic = rows.jacobianRow(r, PARTICLES);
        for (int i = 0; i < PARTICLES; ++i)
          for (int axis = 0; axis < 3; ++axis)
          {
            Points plus = p, minus = p;
            plus(axis, i) += STEP;
            minus(axis, i) -= STEP;
            const double numerical = (evaluateRecord(record, surfaces(), plus, zero).value[r] -
                                      evaluateRecord(record, surfaces(), minus, zero).value[r]) /
                                     (2 * STEP);
            EXPECT_NEAR(analytic(axis, i), numerical, 1e-6 * (1.0 + std::abs(numerical)))
                << "particle " << i << " axis " << axis;
          }
        // Jdot v against d/dt (J v) along v
        const Points forward_p = p + STEP * v, backward_p = p - STEP * v;
        const double numerical = (evaluateRecord(record, surfaces(), forward_p, v).jv(r, v) -
                                  evaluateRecord(record, surfaces(), backward_p, v).jv(r, v)) /
                                 (2 * STEP);
        EXPECT_NEAR(rows.jdot_v[r], numerical, 1e-5 * (1.0 + std::abs(numerical)));
      }
    }
  }
}

// Eliminated kinds: the imposed velocity is the derivative of the imposed position, and the
// imposed acceleration that of the velocity; the particle it names is the one it holds.
TYPED_TEST(EliminatedKind, ImposedMotionIsConsistent)
{
  using Kind = TypeParam;
  bool moved = false;
  {
    Random random(200 + Constraint(Kind{}).index());
    for (int trial = 0; trial < TRIALS; ++trial)
    {
      Points p, v;
      const Kind record = randomCase<Kind>(random, p, v);
      const double t = random.uniform(0.0, 3.0);
      // a tracked kind's path: random knots about every 0.1 s over [-1, 4] s
      std::vector<AnchorTrack> tracks(1, AnchorTrack(p.col(eliminatedParticle(record))));
      for (double knot = -1.0; knot < 4.0; knot += random.uniform(0.05, 0.15))
      {
        AnchorSample sample;
        sample.time = knot;
        sample.position = random.vector(1.5);
        EXPECT_EQ(tracks[0].append(sample, -2.0), AnchorTrack::Append::Taken);
      }
      const ImposedMotion now = imposedMotionOf(record, t, tracks);
      const ImposedMotion later = imposedMotionOf(record, t + STEP, tracks);
      const ImposedMotion earlier = imposedMotionOf(record, t - STEP, tracks);
      const Vec3 velocity = (later.position - earlier.position) / (2 * STEP);
      const Vec3 acceleration = (later.velocity - earlier.velocity) / (2 * STEP);
      EXPECT_LE((now.velocity - velocity).norm(), 1e-6 * (1.0 + velocity.norm())) << trial;
      EXPECT_LE((now.acceleration - acceleration).norm(), 1e-6 * (1.0 + acceleration.norm()))
          << trial;
      EXPECT_GE(eliminatedParticle(Constraint(record)), 0);
      EXPECT_LT(eliminatedParticle(Constraint(record)), PARTICLES);
      moved = moved || (later.position - now.position).norm() > 0.0;
    }
  }
  // a kind that moves its particle in time does work: it says DRIVEN, or the ledger misses it
  EXPECT_EQ(moved, IsDriven<Kind>::value);
  EXPECT_EQ(moved, isDriven(Constraint(Kind{})));
}

// Conservative forces: f = -grad U, and f does not depend on velocity. The others add nothing to
// the potential energy the diagnostics report.
TYPED_TEST(ForceKind, ConservativeForcesAreMinusTheGradientOfTheirPotential)
{
  using Kind = TypeParam;
  Random random(300 + Force(Kind{}).index());
  const std::vector<double> masses{ 0.5, 1.0, 2.0, 0.25, 4.0 };
  for (int trial = 0; trial < TRIALS; ++trial)
  {
    Points p(3, PARTICLES), v(3, PARTICLES);
    for (int i = 0; i < PARTICLES; ++i)
    {
      p.col(i) = random.vector(1.5);
      v.col(i) = random.vector(2.0);
    }
    const Kind force = randomRecord<Kind>(random);
    validateForce(Force(force), PARTICLES, "force");
    Points f = Points::Zero(3, PARTICLES);
    accumulateForce(force, masses, p, v, f);
    EXPECT_TRUE(f.allFinite());
    if constexpr (Kind::CONSERVATIVE)
    {
      Points at_rest = Points::Zero(3, PARTICLES);
      accumulateForce(force, masses, p, Points::Zero(3, PARTICLES), at_rest);
      EXPECT_EQ(f, at_rest);
      for (int i = 0; i < PARTICLES; ++i)
        for (int axis = 0; axis < 3; ++axis)
        {
          Points plus = p, minus = p;
          plus(axis, i) += STEP;
          minus(axis, i) -= STEP;
          const double gradient =
              (potentialEnergy(force, masses, plus) - potentialEnergy(force, masses, minus)) /
              (2 * STEP);
          EXPECT_NEAR(f(axis, i), -gradient, 1e-6 * (1.0 + std::abs(gradient)))
              << Kind::KIND << " particle " << i << " axis " << axis;
        }
    }
    else
    {
      EXPECT_EQ(potentialEnergy(force, masses, p), 0.0) << Kind::KIND;
    }
  }
}

// Every kind can be named in a scene file and validates its own fields: a value outside a
// field's range is refused naming the field.
TYPED_TEST(ConstraintKind, OutOfRangeFieldsAreRefusedNamingThem)
{
  using Kind = TypeParam;
  Random random(400 + Constraint(Kind{}).index());
  Points p, v;
  const Kind valid = randomCase<Kind>(random, p, v);
  int checked = 0;
  forEachField<Kind>(
      [&](const auto& spec)
      {
        using Member = std::decay_t<decltype(valid.*(spec.member))>;
        Kind bad = valid;
        if constexpr (std::is_same_v<Member, double>)
          bad.*(spec.member) = spec.range->high * 2 + 1;
        else if constexpr (std::is_same_v<Member, Vec3>)
          (bad.*(spec.member)).x() = NAN;
        else if constexpr (std::is_same_v<Member, int>)
          bad.*(spec.member) = -1;
        else if constexpr (std::is_same_v<Member, std::string>)
          bad.*(spec.member) = (valid.*(spec.member)).empty() ? "other" : "";  // none, or both
        else if constexpr (std::is_same_v<Member, Shape>)
        {
          (bad.*(spec.member)).type = ShapeType::Sphere;
          (bad.*(spec.member)).radius = -1.0;
        }
        else
          (bad.*(spec.member))[0] = PARTICLES;
        try
        {
          validateConstraint(Constraint(bad), PARTICLES, 1, "record");
          ADD_FAILURE() << Kind::KIND << "." << spec.name << ": accepted a bad value";
        }
        catch (const InvalidInput& e)
        {
          EXPECT_EQ(e.field().rfind(std::string("record.") + spec.name, 0), 0u) << e.what();
        }
        ++checked;
      });
  EXPECT_GT(checked, 0);
}
