// Writes the core's integrator table, one "name<TAB>description" line per row in its order, to
// the file named by its argument: cfg/Simulator.cfg builds dynamic_reconfigure's integrator enum
// from it at build time, so the enum is the table itself (no second list, no parsing of C++).
#include "constrained_particles/core/integrators.hpp"

#include <fstream>
#include <iostream>

int main(int argc, char** argv)
{
  if (argc != 2)
  {
    std::cerr << "usage: integrator_list OUTPUT\n";
    return 2;
  }
  std::ofstream out(argv[1]);
  for (const constrained_particles::IntegratorInfo* info : constrained_particles::integratorTable())
    out << info->name << '\t' << info->description << '\n';
  out.close();
  if (!out)
  {
    std::cerr << "integrator_list: cannot write " << argv[1] << "\n";
    return 1;
  }
  return 0;
}
