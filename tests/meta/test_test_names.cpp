// CTest runs each test case by name (catch_discover_tests). A name with ';'
// is split into two names by CMake's list handling, and an unbalanced '['
// swallows every name after it, so those cases would silently not run (the
// ctest entry matches nothing; -w NoTests in tests/CMakeLists.txt turns that
// into a failure). This keeps every name safe to pass through CMake.
#include <string>

#include <catch2/catch.hpp>

TEST_CASE("every test case name passes through CMake unchanged: no semicolon, brackets balanced", "[meta]") {
  const auto& tests = Catch::getRegistryHub().getTestCaseRegistry().getAllTests();
  REQUIRE(tests.size() > 100);
  for (const Catch::TestCase& test : tests) {
    const std::string& name = test.getTestCaseInfo().name;
    INFO(name);
    CHECK(name.find(';') == std::string::npos);
    int depth = 0;
    bool balanced = true;
    for (char c : name) {
      if (c == '[') ++depth;
      if (c == ']' && --depth < 0) balanced = false;
    }
    CHECK((balanced && depth == 0));
  }
}
