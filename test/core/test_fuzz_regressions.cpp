// Replays every input in test/fuzz/regressions/ (the findings of scripts/fuzz.sh, and seeds):
// each must be refused or run cleanly, as the fuzzer demands.
#include "../fuzz/fuzz_input.hpp"

#include <gtest/gtest.h>

#include <dirent.h>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

TEST(FuzzRegressions, EveryStoredInputRunsCleanly)
{
  const std::string directory = FUZZ_REGRESSIONS_DIR;
  std::vector<std::string> files;
  if (DIR* dir = opendir(directory.c_str()))
  {
    while (const dirent* entry = readdir(dir))
      if (entry->d_name[0] != '.')
        files.push_back(directory + "/" + entry->d_name);
    closedir(dir);
  }
  ASSERT_FALSE(files.empty()) << "no inputs in " << directory;
  for (const std::string& file : files)
  {
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    SCOPED_TRACE(file);
    // aborts (and so fails) on a finding; an escaping exception fails the test
    EXPECT_NO_THROW(constrained_particles::fuzz::runInput(
        reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  }
}
