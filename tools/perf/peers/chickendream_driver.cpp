// Timing driver for chickendream's grain core (fgrn::GenGrain), for the
// side-by-side comparison in docs/performance/peers.md. Written for filmgrain;
// it contains no chickendream code and only calls its public classes. Built
// against a chickendream checkout by build_chickendream.sh (never committed).
//
//   chickendream_driver --w W --h H --rad R [--res N] [--sigma S] [--dev D]
//                       [--threads T] [--in FILE.f32] [--pgm OUT.pgm]
//                       [--raw OUT.f32] [--seed N] [--draft]
//
// Input: --in is W*H little-endian float32, linear light in [0, 1] (the
// plugin's input: linear, clipped to [0, 1]); without it, a horizontal
// ramp from 0 to 1. Renders one plane on T threads with GenGrain's
// multi-thread interface (pass 1 on T threads, then pass 2 on T threads:
// what the plugin does with AVSTP, here with std::thread). Prints the
// render's wall time (pass 1 + pass 2, the filter built before) and the
// mean of input and output.

#include "fgrn/GenGrain.h"
#include "fgrn/VisionFilter.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace
{

void usage()
{
	std::fprintf(stderr,
		"usage: chickendream_driver --w W --h H --rad R [--res N] [--sigma S] [--dev D]\n"
		"                           [--threads T] [--in FILE.f32] [--pgm OUT.pgm]\n"
		"                           [--raw OUT.f32] [--seed N] [--draft] [--noavx]\n");
	std::exit(2);
}

double mean_of(const std::vector<float> &v)
{
	double s = 0;
	for (float x : v)
		s += x;
	return v.empty() ? 0.0 : s / double(v.size());
}

// Runs body(t) for every t in [0, n), each on a thread of its own, and
// waits for them all.
template <typename Body>
void run_threads(int n, const Body &body)
{
	std::vector<std::thread> pool;
	for (int t = 0; t < n; ++t)
		pool.emplace_back([&body, t] { body(t); });
	for (auto &th : pool)
		th.join();
}

} // namespace

int main(int argc, char **argv)
{
	int w = 0, h = 0, res = 100, threads = 2;
	float rad = 0, sigma = 0.35f, dev = 0;
	unsigned seed = 12345;
	bool draft = false, avx = true;
	std::string in_path, pgm_path, raw_path;
	for (int i = 1; i < argc; ++i)
	{
		const std::string a = argv[i];
		auto next = [&]() -> const char * {
			if (i + 1 >= argc)
				usage();
			return argv[++i];
		};
		if (a == "--w") w = std::atoi(next());
		else if (a == "--h") h = std::atoi(next());
		else if (a == "--rad") rad = float(std::atof(next()));
		else if (a == "--res") res = std::atoi(next());
		else if (a == "--sigma") sigma = float(std::atof(next()));
		else if (a == "--dev") dev = float(std::atof(next()));
		else if (a == "--threads") threads = std::atoi(next());
		else if (a == "--seed") seed = unsigned(std::strtoul(next(), nullptr, 10));
		else if (a == "--in") in_path = next();
		else if (a == "--pgm") pgm_path = next();
		else if (a == "--raw") raw_path = next();
		else if (a == "--draft") draft = true;
		else if (a == "--noavx") avx = false;
		else usage();
	}
	if (w <= 0 || h <= 0 || rad <= 0 || res <= 0 || threads <= 0)
		usage();

	const auto t0 = std::chrono::steady_clock::now();

	std::vector<float> src(size_t(w) * h), dst(size_t(w) * h, 0.f);
	if (!in_path.empty())
	{
		FILE *f = std::fopen(in_path.c_str(), "rb");
		if (f == nullptr || std::fread(src.data(), sizeof(float), src.size(), f) != src.size())
		{
			std::fprintf(stderr, "cannot read %zu floats from %s\n", src.size(), in_path.c_str());
			return 1;
		}
		std::fclose(f);
	}
	else
	{
		for (int y = 0; y < h; ++y)
			for (int x = 0; x < w; ++x)
				src[size_t(y) * w + x] = float(x) / float(w - 1);
	}
	for (auto &v : src) // the plugin clips its input to [0, 1]
		v = std::min(std::max(v, 0.f), 1.f);

	const auto t1 = std::chrono::steady_clock::now();

	// The plugin's order: the filter is built once per clip (GrainProc's
	// constructor), then each plane is rendered. The filter is timed apart.
	const fgrn::VisionFilter filter(sigma, res, rad, dev);
	const auto t2 = std::chrono::steady_clock::now();

	fgrn::GenGrain gen(true, avx); // SSE2 path always, AVX path unless --noavx
	const int n = gen.mt_start(dst.data(), src.data(), w, h, w, w, filter, seed, draft, threads);
	run_threads(n, [&gen](int t) { gen.mt_proc_pass1(t); });
	const auto t3 = std::chrono::steady_clock::now();
	if (!draft)
	{
		gen.mt_prepare_pass2();
		run_threads(n, [&gen](int t) { gen.mt_proc_pass2(t); });
	}
	const auto t4 = std::chrono::steady_clock::now();

	auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
	std::printf("size %dx%d rad %g res %d sigma %g dev %g threads %d avx %d draft %d\n",
		w, h, double(rad), res, double(sigma), double(dev), n, int(avx), int(draft));
	std::printf("read %.3f s  filter %.3f s  pass1 %.3f s  pass2 %.3f s  render %.3f s\n",
		secs(t0, t1), secs(t1, t2), secs(t2, t3), secs(t3, t4), secs(t2, t4));
	std::printf("mean in %.5f  mean out %.5f\n", mean_of(src), mean_of(dst));

	if (!raw_path.empty())
	{
		FILE *f = std::fopen(raw_path.c_str(), "wb");
		if (f == nullptr || std::fwrite(dst.data(), sizeof(float), dst.size(), f) != dst.size())
			return 1;
		std::fclose(f);
	}
	if (!pgm_path.empty())
	{
		// 16-bit PGM, sRGB-encoded for viewing
		FILE *f = std::fopen(pgm_path.c_str(), "wb");
		if (f == nullptr)
			return 1;
		std::fprintf(f, "P5\n%d %d\n65535\n", w, h);
		std::vector<unsigned char> row(size_t(w) * 2);
		for (int y = 0; y < h; ++y)
		{
			for (int x = 0; x < w; ++x)
			{
				const float v = std::min(std::max(dst[size_t(y) * w + x], 0.f), 1.f);
				const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
				const unsigned q = unsigned(std::lround(e * 65535.f));
				row[2 * x] = (unsigned char)(q >> 8);
				row[2 * x + 1] = (unsigned char)(q & 255);
			}
			std::fwrite(row.data(), 1, row.size(), f);
		}
		std::fclose(f);
	}
	return 0;
}
