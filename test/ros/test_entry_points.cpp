// Every numeric setting through the node's entry points: start-up parameters (read as the node
// reads them, readParameters), services (~set_chain, ~set_surface, ~step, ~set_state) and
// dynamic_reconfigure (~set_parameters) of the running node. NaN, +-Inf, just below and just above
// the range in limits.hpp are refused naming the field, and nothing changes (reconfigure: the old
// value stays); values on the edges of the range are taken exactly as given. The core's own entry
// points (a core call, a scene file) are test/core/test_entry_points.cpp.
#include "constrained_particles/SimState.h"
#include "constrained_particles/SimulatorConfig.h"
#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/ros/parameters.hpp"

#include <constrained_particles/Reset.h>
#include <constrained_particles/SetChain.h>
#include <constrained_particles/SetState.h>
#include <constrained_particles/SetSurface.h>
#include <constrained_particles/Step.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include "../range_values.hpp"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <thread>
#include <type_traits>

using namespace constrained_particles;
using constrained_particles::testing::badValues;
using constrained_particles::testing::goodValues;

namespace
{
const std::string NODE = "/simulator";

std::string show(double value)
{
  char text[40];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

// One call of the node's service `name` over a persistent connection, made once per service:
// roscpp's one-shot ros::service::call can lose the answer when the server closes its side first
// (ros/ros_comm#1976; it failed CI once at stop 27); a persistent link is not
// closed by the server, so a false here is the node's failure
std::mutex clients_mutex;
std::map<std::string, ros::ServiceClient> clients;  // closed in main, before roscpp shuts down

template <typename Service>
bool callNode(const std::string& name, Service& service)
{
  std::lock_guard<std::mutex> lock(clients_mutex);
  ros::ServiceClient& client = clients[name];
  if (!client.isValid())
  {
    client = ros::NodeHandle().serviceClient<Service>(NODE + "/" + name, true);
    if (!client.waitForExistence(ros::Duration(60.0)))
      return false;
  }
  return client.call(service);
}

template <typename Service>
typename Service::Response call(const std::string& name, typename Service::Request request)
{
  Service service;
  service.request = request;
  EXPECT_TRUE(callNode(name, service)) << name;
  return service.response;
}

void callEmpty(const std::string& name)
{
  std_srvs::Empty empty;
  EXPECT_TRUE(callNode(name, empty)) << name;
}

class EntryPoints : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    ros::NodeHandle nh;
    for (const char* service :
         { "reset", "pause", "step", "set_chain", "set_state", "set_surface", "set_parameters" })
      ASSERT_TRUE(ros::service::waitForService(NODE + "/" + service, ros::Duration(60.0)));
  }

  void SetUp() override
  {
    subscriber_ = nh_.subscribe(NODE + "/state", 10, &EntryPoints::onState, this);
    callEmpty("pause");
    Reset::Request reset;
    reset.scenario = "chain";
    ASSERT_TRUE(call<Reset>("reset", reset).success);
  }

  // the subscriber's callbacks end before the fixture's members do (a race ThreadSanitizer
  // found: onState writing latest_ while the fixture was being destroyed)
  void TearDown() override
  {
    subscriber_.shutdown();
  }

  void onState(const SimState& state)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = state;
    ++received_;
  }

  // a ~state published after this call (waits against the wall clock)
  SimState freshState()
  {
    long seen;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      seen = received_;
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline)
    {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        // two more: the first may have been on its way already
        if (received_ >= seen + 2)
          return latest_;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "no fresh ~state";
    return latest_;
  }

  static void expectSameState(const SimState& before, const SimState& after,
                              const std::string& what)
  {
    EXPECT_EQ(after.scenario, before.scenario) << what;
    EXPECT_EQ(after.steps, before.steps) << what;
    EXPECT_EQ(after.sim_time, before.sim_time) << what;
    ASSERT_EQ(after.positions.size(), before.positions.size()) << what;
    for (std::size_t i = 0; i < before.positions.size(); ++i)
      EXPECT_EQ(after.positions[i], before.positions[i]) << what;
  }

  ros::NodeHandle nh_;
  ros::Subscriber subscriber_;
  std::mutex mutex_;
  SimState latest_;
  long received_ = 0;
};

// a ~set_chain request for a pinned chain of n particles, with `field` (link_length or
// particle_mass) set to value and the other at a valid default
SetChain::Request chainRequest(std::uint32_t n, const std::string& field, double value)
{
  SetChain::Request request;
  request.num_particles = n;
  request.link_length = 0.5;
  request.particle_mass = 1.0;
  request.pin_first = true;
  (field == "link_length" ? request.link_length : request.particle_mass) = value;
  return request;
}

// a parameter set as a double, or as an int when the range holds counts and the value is whole
void setParameter(ros::NodeHandle& nh, const std::string& name, double value, const Range& range)
{
  if (range.integer && std::isfinite(value) && value == std::floor(value) && std::abs(value) < 2e9)
    nh.setParam(name, static_cast<int>(value));
  else
    nh.setParam(name, value);
}

}  // namespace

// Start-up parameters, read by the node's own readParameters from a namespace of their own.
TEST_F(EntryPoints, StartupParameters)
{
  ros::NodeHandle scratch("/entry_points_startup");
  std::vector<std::string> names;
  forEachField<StepSettings>([&](const auto& spec) { names.push_back(spec.name); });
  forEachField<NodeParameters>([&](const auto& spec) { names.push_back(spec.name); });
  for (const char* name : { "damping", "chain/link_length", "chain/particle_mass" })
    names.push_back(name);
  int checked = 0;
  for (const std::string& name : names)
  {
    const Range* range = settingRange(name);
    if (range == nullptr)
      continue;
    for (double bad : badValues(*range))
    {
      scratch.deleteParam("");
      setParameter(scratch, name, bad, *range);
      try
      {
        readParameters(scratch);
        ADD_FAILURE() << "~" << name << " = " << show(bad) << " accepted";
      }
      catch (const InvalidInput& e)
      {
        EXPECT_EQ(e.field(), "~" + name) << e.what();
      }
      ++checked;
    }
    for (double good : goodValues(*range))
    {
      scratch.deleteParam("");
      setParameter(scratch, name, good, *range);
      NodeParameters read;
      try
      {
        read = readParameters(scratch);
      }
      catch (const InvalidInput& e)
      {
        ADD_FAILURE() << "~" << name << " = " << show(good) << " refused: " << e.what();
        continue;
      }
      // what was read is what was set, to the last bit
      double value = NAN;
      auto find = [&](const auto& record)
      {
        return [&](const auto& spec)
        {
          using Member = typename std::decay_t<decltype(spec)>::MemberType;
          if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, int>)
            if (name == spec.name)
              value = record.*(spec.member);
        };
      };
      forEachField<StepSettings>(find(read.step));
      forEachField<NodeParameters>(find(read));
      if (name == "damping")
        value = *read.overrides.damping;
      if (name == "chain/link_length")
        value = *read.overrides.link_length;
      if (name == "chain/particle_mass")
        value = *read.overrides.particle_mass;
      EXPECT_EQ(value, good) << "~" << name;
      ++checked;
    }
  }
  // gravity is a vector: each component
  for (int axis = 0; axis < 3; ++axis)
    for (double bad : badValues(limits::GRAVITY))
    {
      scratch.deleteParam("");
      std::vector<double> gravity{ 0.0, 0.0, -9.81 };
      gravity[axis] = bad;
      scratch.setParam("gravity", gravity);
      try
      {
        readParameters(scratch);
        ADD_FAILURE() << "~gravity[" << axis << "] = " << show(bad) << " accepted";
      }
      catch (const InvalidInput& e)
      {
        EXPECT_EQ(e.field().rfind("~gravity", 0), 0u) << e.what();
      }
      ++checked;
    }
  scratch.deleteParam("");
  EXPECT_GT(checked, 100);
}

// ~set_chain, ~step and ~set_state: refused naming the field, the state untouched; edges taken.
TEST_F(EntryPoints, Services)
{
  const SimState before = freshState();
  const std::vector<std::pair<std::string, const Range*>> chain_fields = {
    { "link_length", &limits::LINK_LENGTH }, { "particle_mass", &limits::MASS }
  };
  for (const auto& [field, range] : chain_fields)
    for (double bad : badValues(*range))
    {
      const SetChain::Response response = call<SetChain>("set_chain", chainRequest(5, field, bad));
      EXPECT_FALSE(response.success) << field << " = " << show(bad);
      EXPECT_NE(response.message.find(field), std::string::npos) << response.message;
    }
  for (std::uint32_t bad : { 0u, 100001u, 4294967295u })  // ~max_particles is 100000
  {
    SetChain::Request request;
    request.num_particles = bad;
    request.link_length = 0.5;
    request.particle_mass = 1.0;
    const SetChain::Response response = call<SetChain>("set_chain", request);
    EXPECT_FALSE(response.success) << bad;
    EXPECT_NE(response.message.find("num_particles"), std::string::npos) << response.message;
  }
  for (std::uint32_t bad : { 0u, static_cast<std::uint32_t>(limits::STEPS_PER_CALL.high + 1) })
  {
    Step::Request request;
    request.steps = bad;
    const Step::Response response = call<Step>("step", request);
    EXPECT_FALSE(response.success) << bad;
    EXPECT_NE(response.message.find("steps"), std::string::npos) << response.message;
  }
  for (const bool velocity : { false, true })
    for (double bad : badValues(velocity ? limits::VELOCITY : limits::COORDINATE))
    {
      SetState::Request request;
      request.positions = before.positions;
      request.velocities.resize(before.positions.size());
      if (velocity)
        request.velocities[2].y = bad;
      else
        request.positions[2].y = bad;
      const SetState::Response response = call<SetState>("set_state", request);
      EXPECT_FALSE(response.success) << show(bad);
      EXPECT_NE(response.message.find(velocity ? "velocities[2].y" : "positions[2].y"),
                std::string::npos)
          << response.message;
    }
  expectSameState(before, freshState(), "after refused requests");

  // the edges of each range, taken as given
  for (const auto& [field, range] : chain_fields)
    for (double good : goodValues(*range))
    {
      const SetChain::Response response = call<SetChain>("set_chain", chainRequest(3, field, good));
      EXPECT_TRUE(response.success) << field << " = " << show(good) << ": " << response.message;
      if (field == "link_length")
      {
        const SimState state = freshState();
        ASSERT_EQ(state.positions.size(), 3u);
        EXPECT_EQ(state.positions[1].x - state.positions[0].x, good);
      }
    }
  Step::Request one;
  one.steps = static_cast<std::uint32_t>(limits::STEPS_PER_CALL.low);
  EXPECT_TRUE(call<Step>("step", one).success);

  // a free particle: any coordinate and velocity in range is kept exactly
  const std::string path = "/tmp/constrained_particles_entry_points.yaml";
  std::ofstream(path) << "particles: [{mass: 1}]\n";
  Reset::Request reset;
  reset.scenario = path;
  ASSERT_TRUE(call<Reset>("reset", reset).success);
  for (double good : goodValues(limits::COORDINATE))
  {
    SetState::Request request;
    request.positions.resize(1);
    request.velocities.resize(1);
    request.positions[0].x = good;
    request.velocities[0].z = goodValues(limits::VELOCITY)[0];
    const SetState::Response response = call<SetState>("set_state", request);
    EXPECT_TRUE(response.success) << show(good) << ": " << response.message;
    const SimState state = freshState();
    EXPECT_EQ(state.positions[0].x, good);
    EXPECT_EQ(state.velocities[0].z, limits::VELOCITY.low);
  }
  std::remove(path.c_str());
}

// ~set_surface: every coefficient of every surface type, refused out of range naming its index
// and name with the state untouched, taken at the edges of its range
TEST_F(EntryPoints, SetSurface)
{
  // a bead at rest at the origin: every coefficient in range gives a height and slope in range
  const std::string path = "/tmp/constrained_particles_entry_points_surface.yaml";
  std::ofstream(path) << "surfaces: {ground: {type: plane}}\n"
                         "particles: [{mass: 1, position: [0, 0, 0]}]\n"
                         "constraints: [{type: surface, particle: 0, surface: ground}]\n";
  Reset::Request reset;
  reset.scenario = path;
  ASSERT_TRUE(call<Reset>("reset", reset).success);
  const SimState before = freshState();
  int checked = 0;
  for (const std::string& type : surfaceTypeNames())
  {
    if (type == "expression")
      continue;
    const std::vector<CoefficientSpec>& specs = surfaceCoefficientSpecs(parseSurfaceType(type));
    for (std::size_t i = 0; i < specs.size(); ++i)
    {
      const std::string field = "coefficients[" + std::to_string(i) + "] (" + specs[i].name + ")";
      SetSurface::Request request;
      request.type = type;
      for (const CoefficientSpec& spec : specs)
        request.coefficients.push_back(spec.default_value);
      for (double bad : badValues(specs[i].range))
      {
        request.coefficients[i] = bad;
        const SetSurface::Response response = call<SetSurface>("set_surface", request);
        EXPECT_FALSE(response.success) << type << " " << field << " = " << show(bad);
        EXPECT_NE(response.message.find(field), std::string::npos) << response.message;
        ++checked;
      }
      expectSameState(before, freshState(), "after refused " + type + " " + field);
      for (double good : goodValues(specs[i].range))
      {
        request.coefficients[i] = good;
        const SetSurface::Response response = call<SetSurface>("set_surface", request);
        EXPECT_TRUE(response.success)
            << type << " " << field << " = " << show(good) << ": " << response.message;
        ++checked;
      }
      ASSERT_TRUE(call<Reset>("reset", reset).success);
    }
  }
  SetSurface::Request formula;
  formula.type = "expression";
  formula.expression = "0.3*sin(2*x)*";
  const SetSurface::Response refused = call<SetSurface>("set_surface", formula);
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.message.find("expression"), std::string::npos) << refused.message;
  expectSameState(before, freshState(), "after a refused expression");
  EXPECT_GT(checked, 50);
  std::remove(path.c_str());
}

// ~reset takes each scene's own step settings, with nothing carried over from the scene before;
// a setting the user changes with dynamic_reconfigure then wins over every scene's
TEST_F(EntryPoints, ResetTakesEachScenesSettingsAndTheUsersChoices)
{
  Reset::Request pendulum, chain;
  pendulum.scenario = "pinned_pendulum";  // its file asks for velocity_verlet
  chain.scenario = "chain";               // its file asks for nothing
  const Reset::Response first = call<Reset>("reset", pendulum);
  EXPECT_NE(first.message.find("velocity_verlet"), std::string::npos) << first.message;
  const Reset::Response second = call<Reset>("reset", chain);
  EXPECT_NE(second.message.find("rk4 + projection"), std::string::npos) << second.message;

  dynamic_reconfigure::Reconfigure choose;
  dynamic_reconfigure::StrParameter integrator;
  integrator.name = "integrator";
  integrator.value = "midpoint";
  choose.request.config.strs.push_back(integrator);
  ASSERT_TRUE(callNode("set_parameters", choose));
  const Reset::Response chosen = call<Reset>("reset", pendulum);
  EXPECT_NE(chosen.message.find("midpoint"), std::string::npos) << chosen.message;
  choose.request.config.strs[0].value = "rk4";
  ASSERT_TRUE(callNode("set_parameters", choose));
}

// dynamic_reconfigure: every reconfigurable number, through ~set_parameters as dynparam sends it
TEST_F(EntryPoints, Reconfigure)
{
  // one set_parameters call with a double (DoubleParameter) or an int (IntParameter): the value
  // the answer shows for `name`
  auto set = [](const std::string& name, auto value)
  {
    using Value = decltype(value);
    constexpr bool whole = std::is_same_v<Value, int>;
    auto numbers = [](dynamic_reconfigure::Config & config) -> auto&
    {
      if constexpr (whole)
        return config.ints;
      else
        return config.doubles;
    };
    dynamic_reconfigure::Reconfigure service;
    typename std::decay_t<decltype(numbers(service.request.config))>::value_type parameter;
    parameter.name = name;
    parameter.value = value;
    numbers(service.request.config).push_back(parameter);
    EXPECT_TRUE(callNode("set_parameters", service));
    for (const auto& p : numbers(service.response.config))
      if (p.name == name)
        return static_cast<Value>(p.value);
    ADD_FAILURE() << name << " missing from the answer";
    return whole ? Value(-1) : Value(NAN);
  };
  auto reconfigure = [&set](const std::string& name, double value) { return set(name, value); };
  const dynamic_reconfigure::ConfigDescription description =
      SimulatorConfig::__getDescriptionMessage__();
  int checked = 0;
  for (const auto& parameter : description.dflt.doubles)
  {
    const std::string& name = parameter.name;
    const Range* range = settingRange(name);
    ASSERT_NE(range, nullptr) << name;
    const double kept = reconfigure(name, parameter.value);  // a known value first
    EXPECT_EQ(kept, parameter.value) << name;
    for (double bad : badValues(*range))
    {
      const double answer = reconfigure(name, bad);
      EXPECT_EQ(answer, kept) << name << " = " << show(bad) << " was not refused";
      ++checked;
    }
    for (double good : goodValues(*range))
    {
      EXPECT_EQ(reconfigure(name, good), good) << name << " = " << show(good) << " was rewritten";
      ++checked;
    }
    reconfigure(name, parameter.value);
  }
  // the whole numbers (max_substeps): one past each end refused, the ends and middle taken
  auto reconfigureInt = [&set](const std::string& name, int value) { return set(name, value); };
  for (const auto& parameter : description.dflt.ints)
  {
    const std::string& name = parameter.name;
    const Range* range = settingRange(name);
    ASSERT_NE(range, nullptr) << name;
    ASSERT_TRUE(range->integer) << name;
    const int kept = reconfigureInt(name, parameter.value);
    EXPECT_EQ(kept, parameter.value) << name;
    for (double bad : { range->low - 1, range->high + 1 })
    {
      EXPECT_EQ(reconfigureInt(name, static_cast<int>(bad)), kept)
          << name << " = " << show(bad) << " was not refused";
      ++checked;
    }
    for (double good : goodValues(*range))
    {
      EXPECT_EQ(reconfigureInt(name, static_cast<int>(good)), static_cast<int>(good))
          << name << " = " << show(good) << " was rewritten";
      ++checked;
    }
    reconfigureInt(name, parameter.value);
  }
  EXPECT_FALSE(description.dflt.ints.empty());
  // a new dt is the step the node takes, to the last bit
  const double dt = goodValues(limits::DT)[0];
  ASSERT_EQ(reconfigure("dt", dt), dt);
  Step::Request three;
  three.steps = 3;
  const Step::Response stepped = call<Step>("step", three);
  EXPECT_EQ(stepped.sim_time, dt + dt + dt);
  reconfigure("dt", 0.001);
  EXPECT_GT(checked, 50);

  // a request naming an unknown field, or a known one with the wrong type, is refused whole:
  // the good dt sent with it is not applied either
  auto dtAfter = [](dynamic_reconfigure::Reconfigure service) -> double
  {
    dynamic_reconfigure::DoubleParameter good;
    good.name = "dt";
    good.value = 0.002;
    service.request.config.doubles.push_back(good);
    EXPECT_TRUE(callNode("set_parameters", service));
    for (const auto& p : service.response.config.doubles)
      if (p.name == "dt")
        return p.value;
    return NAN;
  };
  dynamic_reconfigure::Reconfigure unknown;
  dynamic_reconfigure::DoubleParameter typo;
  typo.name = "dtt";
  typo.value = 0.5;
  unknown.request.config.doubles.push_back(typo);
  EXPECT_EQ(dtAfter(unknown), 0.001) << "a request with an unknown field was applied";
  dynamic_reconfigure::Reconfigure wrong_type;
  dynamic_reconfigure::StrParameter as_text;
  as_text.name = "baumgarte_frequency";
  as_text.value = "10";
  wrong_type.request.config.strs.push_back(as_text);
  EXPECT_EQ(dtAfter(wrong_type), 0.001) << "a request with a wrongly typed field was applied";
  EXPECT_EQ(dtAfter(dynamic_reconfigure::Reconfigure{}), 0.002);  // the same dt alone is applied
  reconfigure("dt", 0.001);
}

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "entry_points_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int failed = RUN_ALL_TESTS();
  clients.clear();
  return failed;
}
