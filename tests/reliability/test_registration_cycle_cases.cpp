// Bad-input cases of the modules that join later in the chain: registration (ICP, normals,
// associations, align_depth_view(s)) and the picking cycle. Each part is compiled when its headers exist.
#include <vector>

#include "matrix.hpp"

namespace binpick::reliability {

void add_registration_cases(std::vector<Case>& out) { (void)out; }

void add_cycle_cases(std::vector<Case>& out) { (void)out; }

}  // namespace binpick::reliability
