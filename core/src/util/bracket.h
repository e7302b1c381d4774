// filmgrain: stepping along x until a rising function crosses a target
// (the exposure that gives a density, predicted or measured).
#pragma once

#include <algorithm>

#include "filmgrain/status.h"

namespace filmgrain {

/// Where a walk toward a target ended: [lo, hi] brackets the crossing when
/// `found`; else the walk gave up at x with value y.
struct Bracket {
    bool found = false;
    double lo = 0.0, hi = 0.0;
    double x = 0.0, y = 0.0;
};

/// Steps x from x0 (where f is y0) by `step` (> 0) up when y0 < target,
/// down otherwise, for at most `max_steps` steps, until f(x) reaches the
/// target; f is taken to rise with x. f(x, y) sets y or returns an error,
/// which is returned at once.
template<typename F>
Status bracket_crossing(const F& f, double x0, double y0, double target, double step,
                        int max_steps, Bracket& out)
{
    const double dir = y0 < target ? step : -step;
    out              = Bracket { false, x0, x0, x0, y0 };
    for (int i = 0; i < max_steps; ++i) {
        const double x2 = out.x + dir;
        double y2       = 0.0;
        if (Status s = f(x2, y2); !s)
            return s;
        if ((y2 - target) * dir >= 0.0) {
            out.found = true;
            out.lo    = std::min(out.x, x2);
            out.hi    = std::max(out.x, x2);
            return {};
        }
        out.x = x2;
        out.y = y2;
    }
    return {};
}

}  // namespace filmgrain
