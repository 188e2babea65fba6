// Test helper of tests/raster/test_temporaries.cpp (a program, hence .cc: the
// test binary globs *.cpp): writes two files into FOLDER through one
// raster::OutputSet, as every tool writes its outputs, prints "staged" once
// both temporaries exist and waits for the signal the test sends, as a tool
// would be interrupted in the middle of writing.
//   interrupted_writer FOLDER
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

#include "raster/io/files.h"
#include "raster/temporaries.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: interrupted_writer FOLDER\n");
    return 2;
  }
  gr::raster::remove_temporaries_on_signals();
  const std::string folder = argv[1];
  const std::vector<char> bytes(1 << 16, 'x');
  gr::raster::OutputSet outputs;
  outputs.stage(folder + "/a.bin", bytes.data(), bytes.size());
  outputs.stage(folder + "/b.bin", bytes.data(), bytes.size());
  std::printf("staged\n");
  std::fflush(stdout);
  for (;;) ::pause();
}
