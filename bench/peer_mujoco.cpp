// The peer chain (bench_common.hpp) in MuJoCo 2.2.2, the natural way: reduced coordinates,
// nested bodies joined by ball joints (link lengths exact by construction), body 0 welded to
// the world, RK4 (MuJoCo's recommendation for accuracy in energy-conserving systems).
// tinyxml2 refuses XML nested over 100 deep, so the chain is split across <include> files.
// Usage: bench_peer_mujoco [--out DIR] [--quick]
#include "bench_common.hpp"

#include <mujoco/mujoco.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

namespace
{
constexpr int BODIES_PER_FILE = 80;      // nesting depth per XML file, under tinyxml2's 100
constexpr double SPHERE_RADIUS = 0.005;  // [m]: small, as a point mass

std::string bodyOpen(const bench::PeerChain& chain, int i)
{
  std::ostringstream xml;
  xml << "<body name=\"b" << i << "\" pos=\"" << (i == 0 ? 0.0 : chain.link_length) << " 0 0\">";
  if (i > 0)  // pivot at the parent particle
    xml << "<joint type=\"ball\" pos=\"" << -chain.link_length << " 0 0\"/>";
  xml << "<geom type=\"sphere\" size=\"" << SPHERE_RADIUS << "\" mass=\"" << chain.particle_mass
      << "\" contype=\"0\" conaffinity=\"0\"/>\n";
  return xml.str();
}

// writes the model into `folder` and returns the main file's path
std::string writeModel(const bench::PeerChain& chain, const std::string& folder)
{
  const int files = (chain.n + BODIES_PER_FILE - 1) / BODIES_PER_FILE;
  for (int f = 0; f < files; ++f)
  {
    std::ostringstream xml;
    if (f == 0)
      xml << "<mujoco model=\"peer_chain\">\n<option timestep=\"" << chain.dt
          << "\" integrator=\"RK4\" gravity=\"0 0 " << chain.gravity
          << "\"><flag energy=\"enable\" contact=\"disable\"/></option>\n<worldbody>\n";
    else
      xml << "<mujocoinclude>\n";
    const int first = f * BODIES_PER_FILE, last = std::min(chain.n, first + BODIES_PER_FILE);
    for (int i = first; i < last; ++i)
      xml << bodyOpen(chain, i);
    if (f + 1 < files)
      xml << "<include file=\"chain_" << f + 1 << ".xml\"/>\n";
    for (int i = first; i < last; ++i)
      xml << "</body>";
    xml << (f == 0 ? "\n</worldbody>\n</mujoco>\n" : "\n</mujocoinclude>\n");
    std::ofstream(folder + "/chain_" + std::to_string(f) + ".xml") << xml.str();
  }
  return folder + "/chain_0.xml";
}

bench::PeerResult run(const bench::PeerChain& chain, const std::string& folder)
{
  bench::PeerResult r;
  r.engine = "mujoco_2.2.2";
  r.method = "nested_ball_joints_rk4";
  char error[1000] = "";
  mjModel* model = mj_loadXML(writeModel(chain, folder).c_str(), nullptr, error, sizeof(error));
  if (!model)
  {
    r.n = chain.n;
    r.finite = false;
    r.note = std::string("load failed: ") + error;
    return r;
  }
  mjData* data = mj_makeData(model);
  mj_forward(model, data);
  // body ids: 0 is the world, particle i is body i + 1
  auto link_error = [&]() -> double
  {
    if (data->warning[mjWARN_BADQACC].number > 0)  // MuJoCo resets an unstable state silently
      return NAN;
    const mjtNum* x = data->xpos;
    double worst = std::sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5]);
    for (int i = 1; i < chain.n; ++i)
    {
      const mjtNum* a = x + 3 * i;
      const mjtNum* b = x + 3 * (i + 1);
      const double d = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                 (a[2] - b[2]) * (a[2] - b[2]));
      worst = std::isnan(d) ? NAN : std::max(worst, std::abs(d - chain.link_length));
    }
    return worst;
  };
  // MuJoCo's energy includes the spheres' small rotational inertia
  auto energy = [&] { return data->energy[0] + data->energy[1]; };
  bench::runPeerChain(
      chain, r, [&] { mj_step(model, data); }, link_error, energy);
  r.note += "; energy includes sphere rotation";
  mj_deleteData(data);
  mj_deleteModel(model);
  return r;
}

}  // namespace

int main(int argc, char** argv)
{
  const bench::PeerArguments arguments(argc, argv);
  char folder_template[] = "/tmp/peer_mujoco_XXXXXX";
  const std::string folder = mkdtemp(folder_template);
  std::ofstream csv = arguments.openCsv("peers_mujoco.csv");
  for (int n : bench::peerChainSizes())
  {
    const bench::PeerResult r = run(arguments.chain(n), folder);
    csv << r.csv() << "\n";
    csv.flush();
    bench::reportPeer(r);
  }
  std::system(("rm -rf " + folder).c_str());
  return 0;
}
