// The peer chain (bench_common.hpp) in ODE 0.16, the engine under Gazebo classic: sphere bodies,
// a ball joint pinning body 0 to the world, a DBall (distance) joint per link.
//   quickstep: Gazebo classic's defaults (dWorldQuickStep, 50 iterations, SOR 1.3, ERP 0.2, CFM 0)
//   worldstep: ODE's direct solver (dWorldStep), which ODE's manual recommends for accuracy
// Usage: bench_peer_ode [--out DIR] [--quick]
#include "bench_common.hpp"

#include <ode/ode.h>

#include <cmath>
#include <fstream>
#include <iostream>

namespace
{
constexpr double SPHERE_RADIUS = 0.005;  // [m]: small, as a point mass

bench::PeerResult run(const bench::PeerChain& chain, bool quickstep)
{
  dRandSetSeed(1);  // QuickStep shuffles rows at random
  dWorldID world = dWorldCreate();
  dWorldSetGravity(world, 0, 0, chain.gravity);
  // ERP and CFM before the joints: DBall copies them at creation
  dWorldSetERP(world, 0.2);
  dWorldSetCFM(world, 0.0);
  dWorldSetQuickStepNumIterations(world, 50);
  dWorldSetQuickStepW(world, 1.3);
  std::vector<dBodyID> bodies(chain.n);
  for (int i = 0; i < chain.n; ++i)
  {
    bodies[i] = dBodyCreate(world);
    dMass mass;
    dMassSetSphereTotal(&mass, chain.particle_mass, SPHERE_RADIUS);
    dBodySetMass(bodies[i], &mass);
    dBodySetPosition(bodies[i], i * chain.link_length, 0, 0);
  }
  dJointID pin = dJointCreateBall(world, nullptr);
  dJointAttach(pin, bodies[0], nullptr);
  dJointSetBallAnchor(pin, 0, 0, 0);
  for (int i = 0; i + 1 < chain.n; ++i)
  {
    dJointID link = dJointCreateDBall(world, nullptr);
    dJointAttach(link, bodies[i], bodies[i + 1]);
    dJointSetDBallAnchor1(link, i * chain.link_length, 0, 0);
    dJointSetDBallAnchor2(link, (i + 1) * chain.link_length, 0, 0);
  }

  auto energy = [&]
  {
    double e = 0;
    for (int i = 1; i < chain.n; ++i)  // translational; body 0 is held
    {
      const dReal* v = dBodyGetLinearVel(bodies[i]);
      const dReal* p = dBodyGetPosition(bodies[i]);
      e += 0.5 * chain.particle_mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) -
           chain.particle_mass * chain.gravity * p[2];
    }
    return e;
  };
  auto link_error = [&]() -> double
  {
    const dReal* pin_position = dBodyGetPosition(bodies[0]);
    double worst = std::sqrt(pin_position[0] * pin_position[0] + pin_position[1] * pin_position[1] +
                             pin_position[2] * pin_position[2]);
    for (int i = 0; i + 1 < chain.n; ++i)
    {
      const dReal* a = dBodyGetPosition(bodies[i]);
      const dReal* b = dBodyGetPosition(bodies[i + 1]);
      const double d = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                 (a[2] - b[2]) * (a[2] - b[2]));
      worst = std::isnan(d) ? NAN : std::max(worst, std::abs(d - chain.link_length));
    }
    return worst;
  };
  bench::PeerResult r;
  r.engine = "ode_0.16";
  r.method = quickstep ? "quickstep_gazebo_defaults" : "worldstep_direct";
  bench::runPeerChain(
      chain, r, [&] { quickstep ? dWorldQuickStep(world, chain.dt) : dWorldStep(world, chain.dt); },
      link_error, energy);
  dWorldDestroy(world);
  return r;
}

}  // namespace

int main(int argc, char** argv)
{
  const bench::PeerArguments arguments(argc, argv);
  dInitODE2(0);
  std::ofstream csv = arguments.openCsv("peers_ode.csv");
  for (int n : bench::peerChainSizes())
    for (bool quickstep : { true, false })
    {
      const bench::PeerResult r = run(arguments.chain(n), quickstep);
      csv << r.csv() << "\n";
      csv.flush();
      bench::reportPeer(r);
    }
  dCloseODE();
  return 0;
}
