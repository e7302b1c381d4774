// Tests of the tabulated P(develop | N) against independent runs of the
// chain, and of its error reporting.
#include "engine/kinetics_table.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "expect/expectations.h"

#include <unistd.h>

namespace filmgrain {
namespace {

/// A table of N <= max_photons to a standard error of
/// target_standard_error, from stream stream_key.
DevelopTable::Options table_options(uint64_t max_photons, double target_standard_error,
                                    uint64_t stream_key = 0)
{
    DevelopTable::Options o;
    o.max_photons           = max_photons;
    o.target_standard_error = target_standard_error;
    o.stream_key            = stream_key;
    return o;
}

TEST(DevelopTable, AgreesWithIndependentRunsOfTheChain)
{
    Stock stock;
    const Development dev(stock);
    const KineticsRates rates { 1e7, 1e6, 10 };
    for (double shutter : { 1e-6, 1.0 / 48, 100.0 }) {
        const DevelopTable::Options o = table_options(300, 2e-3, 1);
        const DevelopTable table(rates, shutter, dev, o);
        // The target, plus the bias of runs stopped once decided (at most
        // a thousandth of the target, added to every node's error).
        EXPECT_LE(table.max_standard_error(), 2e-3 * (1 + 1e-3) + 1e-12);
        // Independent estimate (other streams). The difference of two
        // independent estimates has sd sqrt(se1^2 + se2^2); at an
        // interpolated N add the reported interpolation error. 5 sigma.
        DevelopGivenPhotons reference(rates, shutter, dev, 20000, 99);
        for (uint64_t n : { 0u, 3u, 4u, 7u, 20u, 64u, 101u, 250u }) {
            const Estimate e = reference(n);
            const double tol = 5 * std::hypot(e.standard_error, table.max_standard_error())
                               + (n > o.dense_photons ? table.max_interpolation_error() : 0.0);
            EXPECT_NEAR(table.probability(n), e.value, tol) << "shutter " << shutter << " n " << n;
        }
        // N < 4: fog only, exactly.
        EXPECT_EQ(table.probability(2), dev.develop_probability(0));
        EXPECT_GE(table.max_probability(), table.min_probability());
    }
}

void expect_same_table(const DevelopTable& a, const DevelopTable& b)
{
    ASSERT_EQ(a.node_count(), b.node_count());
    for (uint64_t n = 0; n <= a.max_photons(); ++n) {
        ASSERT_EQ(a.probability(n), b.probability(n)) << n;
        ASSERT_EQ(a.standard_error(n), b.standard_error(n)) << n;
    }
    EXPECT_EQ(a.max_interpolation_error(), b.max_interpolation_error());
    EXPECT_EQ(a.total_runs(), b.total_runs());
    EXPECT_EQ(a.total_steps(), b.total_steps());
}

TEST(DevelopTable, BytesGiveTheSameTableOrNone)
{
    Stock stock;
    const Development dev(stock);
    const DevelopTable::Options o = table_options(150, 5e-3, 11);
    const DevelopTable table({ 1e7, 1e6, 10 }, 0.02, dev, o);
    const std::string bytes = table.serialize();
    const auto back         = DevelopTable::deserialize(bytes, o);
    ASSERT_TRUE(back);
    expect_same_table(table, *back);
    // Other options, cut short, or with more after it: none.
    DevelopTable::Options other = o;
    other.stream_key            = 12;
    EXPECT_FALSE(DevelopTable::deserialize(bytes, other));
    EXPECT_FALSE(DevelopTable::deserialize(bytes.substr(0, bytes.size() - 1), o));
    EXPECT_FALSE(DevelopTable::deserialize(bytes.substr(0, bytes.size() / 2), o));
    EXPECT_FALSE(DevelopTable::deserialize(bytes + "x", o));
    EXPECT_FALSE(DevelopTable::deserialize(std::string(), o));
}

/// Sets an environment variable for one scope.
struct ScopedEnv {
    std::string name;
    ScopedEnv(const char* n, const std::string& value) : name(n) { setenv(n, value.c_str(), 1); }
    ~ScopedEnv() { unsetenv(name.c_str()); }
};

TEST(DevelopTable, KeptOnDiskForOtherProcesses)
{
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path()
                         / ("filmgrain-table-cache-test-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    Stock stock;
    const Development dev(stock);
    DevelopTable::Options o  // a stream no table in memory has
        = table_options(120, 8e-3, 0x5eed0000 + static_cast<uint64_t>(::getpid()));
    {
        ScopedEnv env("FILMGRAIN_CACHE_DIR", dir.string());
        if (table_cache_dir().empty())
            GTEST_SKIP() << "this build keeps no tables on disk (no table code id)";
        EXPECT_EQ(table_cache_dir(), dir.string());
        const auto table = shared_develop_table({ 1e7, 1e6, 10 }, 0.02, dev, o);
        ASSERT_TRUE(table->complete());
        // One whole file, no temporary left; it holds the table's bytes
        // (then an 8-byte check).
        std::vector<fs::path> files;
        for (const auto& e : fs::directory_iterator(dir / "tables"))
            files.push_back(e.path());
        ASSERT_EQ(files.size(), 1u);
        EXPECT_EQ(files[0].extension(), ".bin");
        std::ifstream in(files[0], std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
        const std::string own = table->serialize();
        ASSERT_GT(bytes.size(), own.size() + 8);
        EXPECT_TRUE(bytes.compare(bytes.size() - 8 - own.size(), own.size(), own) == 0);
    }
    {
        // "off": nothing written.
        ScopedEnv env("FILMGRAIN_CACHE_DIR", "off");
        EXPECT_EQ(table_cache_dir(), "");
        o.stream_key += 1;
        shared_develop_table({ 1e7, 1e6, 10 }, 0.02, dev, o);
        size_t files = 0;
        for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "tables"))
            ++files;
        EXPECT_EQ(files, 1u);
    }
    fs::remove_all(dir);
}

TEST(DevelopTable, DeterministicForAnyThreadCount)
{
    Stock stock;
    const Development dev(stock);
    DevelopTable::Options o = table_options(200, 5e-3);
    o.nthreads = 1;
    const DevelopTable a({ 1e7, 1e6, 10 }, 0.02, dev, o);
    o.nthreads = 3;
    const DevelopTable b({ 1e7, 1e6, 10 }, 0.02, dev, o);
    expect_same_table(a, b);
}

TEST(DevelopTable, StepBudgetStopsExactlyWhenTheFullCostExceedsIt)
{
    // A build stops (incomplete) iff its full cost exceeds the budget,
    // whatever the thread count; within the budget it is the unlimited
    // build, value for value.
    Stock stock;
    const Development dev(stock);
    const KineticsRates rates { 1e7, 1e6, 10 };
    DevelopTable::Options o = table_options(200, 5e-3);
    const DevelopTable full(rates, 0.02, dev, o);
    ASSERT_TRUE(full.complete());
    const uint64_t cost = full.total_steps();
    ASSERT_GT(cost, full.total_events());  // arrivals count too
    for (int threads : { 1, 3 }) {
        o.nthreads    = threads;
        o.step_budget = cost;
        const DevelopTable enough(rates, 0.02, dev, o);
        EXPECT_TRUE(enough.complete()) << threads;
        EXPECT_EQ(enough.total_steps(), cost);
        for (uint64_t n = 0; n <= 200; ++n)
            ASSERT_EQ(enough.probability(n), full.probability(n)) << n;
        o.step_budget = cost - 1;
        EXPECT_FALSE(DevelopTable(rates, 0.02, dev, o).complete()) << threads;
    }
    // The pilot's prediction of that cost: within a factor of two here
    // (16 runs per node estimate each node's variance and steps per run).
    o.step_budget          = 0;
    const double predicted = DevelopTable::predicted_steps(o, rates, 0.02, dev);
    EXPECT_GT(predicted, 0.5 * static_cast<double>(cost));
    EXPECT_LT(predicted, 2.0 * static_cast<double>(cost));
}

}  // namespace
}  // namespace filmgrain
