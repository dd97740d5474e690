// Uses the installed fuse::query: an invalid time is refused locally, and with no server on the
// domain a query is unavailable after its deadline. Prints "consumer ok" when both hold.
#include <cmath>
#include <cstdlib>
#include <iostream>

#include <fuse/query/client.hpp>

int main(int argc, char** argv) {
  fuse::query::ClientOptions options;
  options.domain_id = argc > 1 ? std::atoi(argv[1]) : 44;
  options.deadline_ms = 200;
  fuse::query::Client client(options);
  const fuse::query::Result invalid = client.at(std::nan(""));
  const fuse::query::Result none = client.latest();
  std::cout << "at(nan): " << fuse::query::to_string(invalid.error) << "\n"
            << "latest(): " << fuse::query::to_string(none.error) << " (" << none.message << ")\n";
  const bool ok = invalid.error == fuse::query::Error::bad_request && none.error == fuse::query::Error::unavailable;
  std::cout << (ok ? "consumer ok" : "consumer FAILED") << "\n";
  return ok ? EXIT_SUCCESS : EXIT_FAILURE;
}
