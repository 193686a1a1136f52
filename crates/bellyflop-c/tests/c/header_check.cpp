// The header compiles as C++ (extern "C", no C-only constructs), and its
// functions link from C++.
#include "bellyflop.h"

#include <cstdio>

int main() {
    bf_settings s = bf_settings_default();
    std::printf("c++: %s %s\n", bf_status_str(BF_STATUS_SOLVED), bf_error_str(BF_ERROR_OK));
    return s.time_budget_s == 0.0 ? 0 : 1;
}
