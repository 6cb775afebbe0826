#include "lightmesh/shadow/light_mesh_kernels.h"

#include <bit>
#include <cstring>
#include <limits>
#include <tuple>
#include <vector>
#include <random>

#include <gtest/gtest.h>

namespace lm::kernels {
namespace light_mesh_kernels_test {
namespace {

// Random triangles near the origin as a cell's front list (structure of arrays, padded as
// LightMesh::FrontTriangles pads it), with patch ranges.
FrontArrays RandomFrontList(std::mt19937& rng, uint32_t count) {
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f), size(0.05f, 1.5f), unit(-1.0f, 1.0f);
    FrontArrays f;
    f.Reserve(count);
    for (uint32_t i = 0; i < count; ++i) {
        const Vec3 a(coord(rng), coord(rng), coord(rng));
        const Vec3 b = a + Vec3(unit(rng), unit(rng), unit(rng)) * size(rng);
        const Vec3 c = a + Vec3(unit(rng), unit(rng), unit(rng)) * size(rng);
        const Vec3 n = Normalize(Cross(b - a, c - a));
        f.nx[i] = n.x, f.ny[i] = n.y, f.nz[i] = n.z, f.d[i] = Dot(n, a);
        const Vec3 lo = Min(a, Min(b, c)) - Vec3(1e-4f), hi = Max(a, Max(b, c)) + Vec3(1e-4f);
        f.lox[i] = lo.x, f.loy[i] = lo.y, f.loz[i] = lo.z, f.hix[i] = hi.x, f.hiy[i] = hi.y, f.hiz[i] = hi.z;
        f.v0x[i] = a.x, f.v0y[i] = a.y, f.v0z[i] = a.z, f.v1x[i] = b.x, f.v1y[i] = b.y, f.v1z[i] = b.z;
        f.v2x[i] = c.x, f.v2y[i] = c.y, f.v2z[i] = c.z;
        const float s0 = unit(rng) * 2, s1 = unit(rng) * 2;
        f.sMin[i] = std::min(s0, s1), f.sMax[i] = std::max(s0, s1);
    }
    f.count = count;
    for (uint32_t i = count; i % 8 != 0; ++i) {
        f.nx[i] = f.ny[i] = f.nz[i] = f.d[i] = f.sMin[i] = f.sMax[i] = 0;
        f.lox[i] = f.loy[i] = f.loz[i] = Infinity;
        f.hix[i] = f.hiy[i] = f.hiz[i] = -Infinity;
        f.v0x[i] = f.v0y[i] = f.v0z[i] = f.v1x[i] = f.v1y[i] = f.v1z[i] = f.v2x[i] = f.v2y[i] = f.v2z[i] = 0;
    }
    return f;
}

// A brick's axis bits decide, for every one of its 64 cells, what the box test against
// the cell's box decides: boxes touching the cells' bounds exactly, inside, around, apart
// (the cell summaries' reach lists are built from them instead of from box tests).
TEST(LightMeshKernels, BrickAxisBitsAgreeWithTheBoxTestOfEveryCell) {
    std::mt19937 rng(20261203);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    uint64_t meets = 0, apart = 0;
    for (int brick = 0; brick < 50; ++brick) {
        // Cells of a lattice with step h from an origin, grown by a margin as ReachBox does.
        const float h = 0.1f + 3 * unit(rng), margin = h * unit(rng) * 0.5f, grow = 3 * unit(rng);
        const Vec3 origin(100 * unit(rng) - 50, 100 * unit(rng) - 50, 100 * unit(rng) - 50);
        const int first = static_cast<int>(40 * unit(rng));
        auto cellBox = [&](int px, int py, int pz, Vec3* lo, Vec3* hi) {
            const int i[3] = {first + px, first + py, first + pz};
            float l[3], u[3];
            for (int a = 0; a < 3; ++a) {
                l[a] = origin[a] + static_cast<float>(i[a]) * h - margin - grow * h;
                u[a] = origin[a] + static_cast<float>(i[a] + 1) * h + margin + grow * h;
            }
            *lo = Vec3(l[0], l[1], l[2]), *hi = Vec3(u[0], u[1], u[2]);
        };
        BrickAxes axes;
        for (int p = 0; p < 4; ++p) {
            Vec3 lo, hi;
            cellBox(p, p, p, &lo, &hi);
            for (int a = 0; a < 3; ++a) axes.lo[a][p] = lo[a], axes.hi[a][p] = hi[a];
        }
        for (int b = 0; b < 200; ++b) {
            // Corners on the cells' bounds (exact touches), or anywhere around the brick.
            Vec3 lo, hi, l2, h2;
            cellBox(static_cast<int>(4 * unit(rng)), static_cast<int>(4 * unit(rng)), static_cast<int>(4 * unit(rng)), &lo, &hi);
            cellBox(static_cast<int>(4 * unit(rng)), static_cast<int>(4 * unit(rng)), static_cast<int>(4 * unit(rng)), &l2, &h2);
            Vec3 blo, bhi;
            for (int a = 0; a < 3; ++a) {
                const float pick[4] = {lo[a], hi[a], l2[a], h2[a]};
                const float x = unit(rng) < 0.5f ? pick[static_cast<int>(4 * unit(rng))]
                                                 : origin[a] + (first - 3 + 10 * unit(rng)) * h;
                const float y = unit(rng) < 0.5f ? pick[static_cast<int>(4 * unit(rng))]
                                                 : origin[a] + (first - 3 + 10 * unit(rng)) * h;
                blo[a] = std::min(x, y), bhi[a] = std::max(x, y);
            }
            const uint32_t bits = BrickAxisBits(axes, blo, bhi);
            for (int pz = 0; pz < 4; ++pz)
                for (int py = 0; py < 4; ++py)
                    for (int px = 0; px < 4; ++px) {
                        Vec3 clo, chi;
                        cellBox(px, py, pz, &clo, &chi);
                        const bool box = bhi.x >= clo.x && blo.x <= chi.x && bhi.y >= clo.y && blo.y <= chi.y &&
                                         bhi.z >= clo.z && blo.z <= chi.z;
                        const uint32_t need = CellBits(px, py, pz);
                        ASSERT_EQ(box, (bits & need) == need) << "brick " << brick << " box " << b << " cell " << px << py << pz;
                        (box ? meets : apart) += 1;
                    }
        }
    }
    EXPECT_GT(meets, 1000u);
    EXPECT_GT(apart, 1000u);
}

// The templates' front test from int8 offsets (one cache line per block): the scalar, SSE
// and AVX2 passes agree bit for bit with the test on float offsets, for offsets over the
// whole range kI ≤ 16 gives, normals in every direction, and ties at eps; a padding lane
// (its bit clear in `lanes`, offsets 0) is never in front, even where (0, 0, 0) would be.
TEST(LightMeshKernels, FrontTestsOfEveryWidthAgreeAndSkipPadding) {
    std::mt19937 rng(20261205);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> offset(-18, 18), lanes(0, 255);
    const FrontFunction widths[3] = {ChooseFrontFunction(1), ChooseFrontFunction(4), ChooseFrontFunction(8)};
    std::vector<FrontBlock> blocks(64);
    uint64_t inFront = 0, padded = 0;
    for (int round = 0; round < 200; ++round) {
        for (FrontBlock& b : blocks) {
            b = FrontBlock{};
            b.lanes = static_cast<uint8_t>(lanes(rng));
            for (int k = 0; k < 8; ++k) {
                b.ox[k] = static_cast<int8_t>(offset(rng)), b.oy[k] = static_cast<int8_t>(offset(rng));
                b.oz[k] = static_cast<int8_t>(offset(rng));
                if (!((b.lanes >> k) & 1)) b.ox[k] = b.oy[k] = b.oz[k] = 0;
            }
        }
        Vec3 n(unit(rng), unit(rng), unit(rng));
        if (round % 4 == 0) n = Vec3(0, 1, 0);  // axis-aligned: exact ties
        n = Normalize(n);
        const float nfrac = round % 3 == 0 ? -1.0f : unit(rng), eps = round % 4 == 0 ? 0.0f : 1e-4f;
        uint8_t masks[3][64];
        for (int w = 0; w < 3; ++w) widths[w](blocks.data(), 64, n, nfrac, eps, masks[w]);
        for (size_t b = 0; b < blocks.size(); ++b) {
            uint8_t want = 0;
            for (int k = 0; k < 8; ++k) {
                const Vec3 o(blocks[b].ox[k], blocks[b].oy[k], blocks[b].oz[k]);
                if (((blocks[b].lanes >> k) & 1) && Dot(n, o) - nfrac > eps) want |= static_cast<uint8_t>(1 << k);
                if (!((blocks[b].lanes >> k) & 1) && Dot(n, o) - nfrac > eps) ++padded;  // (0,0,0) in front
            }
            for (int w = 0; w < 3; ++w) ASSERT_EQ(masks[w][b], want) << "width " << w << " round " << round;
            inFront += static_cast<uint64_t>(std::popcount(want));
        }
    }
    EXPECT_GT(inFront, 10000u);
    EXPECT_GT(padded, 100u);  // the padding's exclusion was tested where it matters
}

// Нет's gathered sums (LightMesh::UseAll) against a sum entry by entry, for node words of
// 1, 2 and 4 bytes and every number of lights they hold: random words (the top bit,
// "initialised", set; the bit below it, "inside", random), random front masks over blocks
// of random nodes, runs longer than 255 blocks (the byte counters' widening), and an entry
// in front not yet evaluated, which must make the sum fail without adding anything.
TEST(LightMeshKernels, GatheredSumsEqualTheEntryByEntrySums) {
    std::mt19937 rng(20261204);
    const uint32_t kNodes = 4096;
    for (const int bytes : {1, 2, 4}) {
        const SumFrontFunction sum = ChooseSumFrontFunction(0, bytes);
        if (!sum) GTEST_SKIP() << "no AVX2 (or ThreadSanitizer): the scalar sums are used";
        const int bits = 8 * bytes;
        // Words as bytes, padded after the last node as LightMesh pads its array.
        std::vector<uint8_t> store((kNodes + 8) * bytes, 0);
        auto word = [&](uint32_t i) {
            uint32_t w = 0;
            std::memcpy(&w, store.data() + size_t(i) * bytes, bytes);
            return w;
        };
        for (const int lights : {1, 2, 3, 4, 5, 6, bits - 2})
        for (const bool allLit : {false, true}) {  // all lit: every counter gains 1 per block
            if (lights > bits - 2) continue;
            for (uint32_t i = 0; i < kNodes; ++i) {
                uint32_t w = (allLit ? ~0u : static_cast<uint32_t>(rng())) & ((1u << lights) - 1);
                w |= (static_cast<uint32_t>(rng()) & 1u) << (bits - 2);  // "inside"
                w |= 1u << (bits - 1);                                    // "initialised"
                std::memcpy(store.data() + size_t(i) * bytes, &w, bytes);
            }
            for (const uint32_t count : {1u, 5u, 40u, 254u, 255u, 256u, 600u}) {
                std::vector<FrontBlock> blocks(count);
                std::vector<uint8_t> masks(count);
                std::uniform_int_distribution<uint32_t> node(0, kNodes - 1);
                for (uint32_t b = 0; b < count; ++b) {
                    blocks[b] = FrontBlock{};
                    blocks[b].lanes = static_cast<uint8_t>(rng());
                    for (int k = 0; k < 8; ++k) blocks[b].linear[k] = static_cast<int32_t>(node(rng));
                    masks[b] = static_cast<uint8_t>(rng() & rng() & blocks[b].lanes);  // a few empty
                    if (count > 200) masks[b] = blocks[b].lanes = 0xFF;  // dense: counters at their limit
                }
                std::vector<uint32_t> want(lights, 7), got(lights, 7);
                uint32_t wantM = 3, gotM = 3;
                for (uint32_t b = 0; b < count; ++b)
                    for (int k = 0; k < 8; ++k) {
                        if (!((masks[b] >> k) & 1)) continue;
                        const uint32_t w = word(static_cast<uint32_t>(blocks[b].linear[k]));
                        ++wantM;
                        for (int l = 0; l < lights; ++l) want[l] += (w >> l) & 1;
                    }
                ASSERT_TRUE(sum(blocks.data(), masks.data(), count, store.data(), lights, got.data(), &gotM));
                EXPECT_EQ(gotM, wantM) << bytes << " bytes, " << lights << " lights, " << count << " blocks";
                EXPECT_EQ(got, want) << bytes << " bytes, " << lights << " lights, " << count << " blocks";
                // One entry in front of the last non-empty block not evaluated: false, nothing added.
                uint32_t last = count;
                while (last > 0 && masks[last - 1] == 0) --last;
                if (last == 0) continue;
                const uint32_t victim = static_cast<uint32_t>(blocks[last - 1].linear[std::countr_zero(masks[last - 1])]);
                const uint32_t saved = word(victim), cleared = saved & ~(1u << (bits - 1));
                std::memcpy(store.data() + size_t(victim) * bytes, &cleared, bytes);
                std::vector<uint32_t> untouched(lights, 7);
                uint32_t m = 3;
                EXPECT_FALSE(sum(blocks.data(), masks.data(), count, store.data(), lights, untouched.data(), &m));
                EXPECT_EQ(m, 3u);
                EXPECT_EQ(untouched, std::vector<uint32_t>(lights, 7));
                std::memcpy(store.data() + size_t(victim) * bytes, &saved, bytes);
            }
        }
    }
}

// Consensus's minority and majority masks (LightMesh::MinorityFirst) against the comparison
// entry by entry, for node words of 1, 2 and 4 bytes: random words whose needed bits are
// the majority's about half the time, random needed masks (so bits not needed differ
// freely, and the bytes above a narrower word, which the gathers load too, hold noise),
// random front masks with empty blocks.
TEST(LightMeshKernels, MinorityMasksEqualTheEntryByEntryComparison) {
    std::mt19937 rng(20261205);
    const uint32_t kNodes = 2048;
    for (const int bytes : {1, 2, 4}) {
        const MinorityFunction split = ChooseMinorityFunction(0, bytes);
        if (!split) GTEST_SKIP() << "no AVX2 (or ThreadSanitizer): the scalar loop is used";
        EXPECT_EQ(ChooseMinorityFunction(1, bytes), nullptr);
        const int bits = 8 * bytes, lights = bits - 2;
        std::vector<uint8_t> store((kNodes + 8) * bytes, 0);
        uint64_t minorities = 0, majorities = 0;
        for (int round = 0; round < 50; ++round) {
            const uint32_t lightBits = lights >= 32 ? ~0u : (1u << lights) - 1;
            uint32_t needed = static_cast<uint32_t>(rng()) & lightBits;
            if (round % 5 == 0) needed = lightBits;
            const uint32_t majority = static_cast<uint32_t>(rng()) & needed;
            for (uint32_t i = 0; i < kNodes + 8; ++i) {
                uint32_t w = static_cast<uint32_t>(rng()) & lightBits;
                if (rng() & 1) w = (w & ~needed) | majority;  // the majority's bits where needed
                w |= 1u << (bits - 1);                          // "initialised"
                std::memcpy(store.data() + size_t(i) * bytes, &w, bytes);
            }
            const uint32_t count = 1 + static_cast<uint32_t>(rng() % 40);
            std::vector<FrontBlock> blocks(count);
            std::vector<uint8_t> masks(count), minority(count, 0xAA), majorityOut(count, 0x55);
            std::uniform_int_distribution<uint32_t> node(0, kNodes - 1);
            for (uint32_t b = 0; b < count; ++b) {
                blocks[b] = FrontBlock{};
                blocks[b].lanes = static_cast<uint8_t>(rng());
                for (int k = 0; k < 8; ++k) blocks[b].linear[k] = static_cast<int32_t>(node(rng));
                masks[b] = static_cast<uint8_t>(rng() & blocks[b].lanes);
            }
            split(blocks.data(), masks.data(), count, store.data(), needed, majority, minority.data(), majorityOut.data());
            for (uint32_t b = 0; b < count; ++b) {
                uint8_t wantMinority = 0, wantMajority = 0;
                for (int k = 0; k < 8; ++k) {
                    if (!((masks[b] >> k) & 1)) continue;
                    uint32_t w = 0;
                    std::memcpy(&w, store.data() + size_t(blocks[b].linear[k]) * bytes, bytes);
                    if ((w & needed) != majority) wantMinority |= static_cast<uint8_t>(1 << k);
                    else wantMajority |= static_cast<uint8_t>(1 << k);
                }
                ASSERT_EQ(minority[b], wantMinority) << bytes << " bytes, round " << round << ", block " << b;
                ASSERT_EQ(majorityOut[b], wantMajority) << bytes << " bytes, round " << round << ", block " << b;
                minorities += static_cast<uint64_t>(std::popcount(wantMinority));
                majorities += static_cast<uint64_t>(std::popcount(wantMajority));
            }
        }
        EXPECT_GT(minorities, 500u) << bytes;
        EXPECT_GT(majorities, 500u) << bytes;
    }
}

// The side summaries' node selection (LightMesh::Side): the AVX2 pass keeps exactly the
// nodes the scalar one does, in the same order, for random cells, lattices and planes,
// with nodes on the plane (hx = 0, axis-aligned planes through a node), a slab that ends
// exactly at a node's |hx|, both sides, and every length up to three groups of four and more.
TEST(LightMeshKernels, SideNodesOfTheVectorPassEqualTheScalarOnes) {
    std::mt19937 rng(20261205);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<int> offset(-4, 5);
    const SideNodesFunction scalar = ChooseSideNodesFunction(1), wide = ChooseSideNodesFunction(8);
    uint64_t kept = 0, onPlane = 0, atSlab = 0;
    for (int round = 0; round < 400; ++round) {
        const uint32_t count = round < 40 ? static_cast<uint32_t>(round) : 1 + static_cast<uint32_t>(rng() % 300);
        std::vector<int8_t> ox(count), oy(count), oz(count);
        for (uint32_t e = 0; e < count; ++e) {
            ox[e] = static_cast<int8_t>(offset(rng));
            oy[e] = static_cast<int8_t>(offset(rng));
            oz[e] = static_cast<int8_t>(offset(rng));
        }
        SideQuery q;
        for (int a = 0; a < 3; ++a) {
            q.cell[a] = static_cast<int>(rng() % 200);
            q.origin[a] = (unit(rng) - 0.5f) * 1000.0f;
        }
        q.h = 0.01f + unit(rng) * 3.0f;
        q.side = round % 2;
        auto node = [&](uint32_t e, int a) {
            const int8_t o = a == 0 ? ox[e] : a == 1 ? oy[e] : oz[e];
            return q.origin[a] + static_cast<float>(q.cell[a] + o) * q.h;
        };
        if (round % 3 == 0 && count > 0) {  // axis-aligned through a node: exact zeros
            const int a = static_cast<int>(rng() % 3);
            q.n[0] = q.n[1] = q.n[2] = 0;
            q.n[a] = rng() & 1 ? 1.0 : -1.0;
            q.d = q.n[a] * node(static_cast<uint32_t>(rng() % count), a);
        } else {
            double n[3] = {unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5};
            const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int a = 0; a < 3; ++a) q.n[a] = n[a] / len;
            q.d = count > 0 ? q.n[0] * node(0, 0) + q.n[1] * node(0, 1) + q.n[2] * node(0, 2) : 0.0;
        }
        q.slab = q.h * (0.5 + 3 * unit(rng));
        if (round % 4 == 1 && count > 1) {  // the slab ends exactly at a node
            const uint32_t e = static_cast<uint32_t>(rng() % count);
            q.slab = std::abs(q.n[0] * node(e, 0) + q.n[1] * node(e, 1) + q.n[2] * node(e, 2) - q.d);
            ++atSlab;
        }
        std::vector<uint32_t> want(count + 1, 7), got(count + 1, 7);
        const uint32_t nWant = scalar(ox.data(), oy.data(), oz.data(), count, q, want.data());
        const uint32_t nGot = wide(ox.data(), oy.data(), oz.data(), count, q, got.data());
        ASSERT_EQ(nGot, nWant) << "round " << round;
        want.resize(nWant);
        got.resize(nGot);
        ASSERT_EQ(got, want) << "round " << round;
        kept += nWant;
        for (uint32_t e = 0; e < count; ++e)
            onPlane += q.n[0] * node(e, 0) + q.n[1] * node(e, 1) + q.n[2] * node(e, 2) - q.d == 0;
    }
    EXPECT_GT(kept, 5000u);
    EXPECT_GT(onPlane, 1000u);  // nodes on Π, which neither side keeps, were there
    EXPECT_GT(atSlab, 50u);
}

// The cell summaries' brick lists (LightMesh::NearCodes, LightMesh::ComputeSummary): the
// AVX2 near codes equal BrickAxisBits' for boxes touching the cells' bounds, around them,
// and with a NaN bound; the filtered lists equal those of the definition, in the list's
// order, for every length up to three groups of eight and every cell of the brick.
TEST(LightMeshKernels, BrickListsOfTheVectorPassesEqualTheScalarOnes) {
    std::mt19937 rng(20261204);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const NearCodesFunction scalarCodes = ChooseNearCodesFunction(1), wideCodes = ChooseNearCodesFunction(8);
    const FilterNearFunction scalarFilter = ChooseFilterNearFunction(1), wideFilter = ChooseFilterNearFunction(8);
    // Boxes laid out as the light mesh's triangle planes: n, d, lo, hi.
    constexpr size_t kStride = 10, kLo = 4;
    uint64_t touched = 0;
    for (int brick = 0; brick < 40; ++brick) {
        BrickAxes reach, cell;
        const float h = 0.05f + unit(rng), grow = 2 * h * unit(rng);
        for (int a = 0; a < 3; ++a)
            for (int p = 0; p < 4; ++p) {
                cell.lo[a][p] = static_cast<float>(p) * h, cell.hi[a][p] = static_cast<float>(p + 1) * h;
                reach.lo[a][p] = cell.lo[a][p] - grow, reach.hi[a][p] = cell.hi[a][p] + grow;
            }
        const uint32_t count = static_cast<uint32_t>(unit(rng) * 300);
        std::vector<float> boxes((count + 5) * kStride, 0.0f);
        std::vector<uint32_t> ids(count);
        for (uint32_t i = 0; i < count; ++i) {
            const uint32_t t = (i * 7 + 3) % (count + 5);  // ids out of order, some skipped
            ids[i] = t;
            float* box = boxes.data() + t * kStride + kLo;
            for (int a = 0; a < 3; ++a) {
                const BrickAxes& axes = unit(rng) < 0.5f ? reach : cell;
                const int p = static_cast<int>(4 * unit(rng));
                const float bound = unit(rng) < 0.5f ? axes.lo[a][p] : axes.hi[a][p];  // an exact touch
                const float x = unit(rng) < 0.4f ? bound : (6 * unit(rng) - 1) * h;
                const float y = unit(rng) < 0.4f ? bound : (6 * unit(rng) - 1) * h;
                box[a] = std::min(x, y), box[3 + a] = std::max(x, y);
                touched += x == bound || y == bound;
            }
            if (i % 37 == 5) box[static_cast<int>(6 * unit(rng))] = std::numeric_limits<float>::quiet_NaN();
        }
        std::vector<uint32_t> codes(count), wide(count);
        scalarCodes(reach, cell, boxes.data() + kLo, kStride, ids.data(), count, codes.data());
        wideCodes(reach, cell, boxes.data() + kLo, kStride, ids.data(), count, wide.data());
        for (uint32_t i = 0; i < count; ++i) {
            const float* box = boxes.data() + ids[i] * kStride + kLo;
            const Vec3 lo(box[0], box[1], box[2]), hi(box[3], box[4], box[5]);
            ASSERT_EQ(codes[i], BrickAxisBits(reach, lo, hi) | BrickAxisBits(cell, lo, hi) << 12) << "brick " << brick;
            ASSERT_EQ(wide[i], codes[i]) << "brick " << brick << " triangle " << i;
        }
        // Every cell of the brick, over every prefix length up to 24 and the whole list.
        std::vector<uint32_t> reachA(count + kFilterSlack), cellA(count + kFilterSlack);
        std::vector<uint32_t> reachB(count + kFilterSlack), cellB(count + kFilterSlack);
        for (int slot = 0; slot < 64; ++slot) {
            const uint32_t reachBits = CellBits(slot & 3, (slot >> 2) & 3, slot >> 4), cellBits = reachBits << 12;
            for (uint32_t n = 0; n <= count; n = n < 24 ? n + 1 : (n == count ? n + 1 : count)) {
                std::vector<uint32_t> wantReach, wantCell;
                for (uint32_t i = 0; i < n; ++i) {
                    if ((codes[i] & reachBits) == reachBits) wantReach.push_back(ids[i]);
                    if ((codes[i] & (reachBits | cellBits)) == (reachBits | cellBits)) wantCell.push_back(ids[i]);
                }
                for (const auto& [filter, r, c] : {std::tuple{scalarFilter, &reachA, &cellA}, std::tuple{wideFilter, &reachB, &cellB}}) {
                    const uint64_t got = filter(ids.data(), codes.data(), n, reachBits, cellBits, r->data(), c->data());
                    ASSERT_EQ(got & 0xffffffffu, wantReach.size()) << "brick " << brick << " cell " << slot << " n " << n;
                    ASSERT_EQ(got >> 32, wantCell.size()) << "brick " << brick << " cell " << slot << " n " << n;
                    ASSERT_TRUE(std::equal(wantReach.begin(), wantReach.end(), r->begin()));
                    ASSERT_TRUE(std::equal(wantCell.begin(), wantCell.end(), c->begin()));
                }
            }
        }
    }
    EXPECT_GT(touched, 1000u);
}

// A point's blocker query as FindBlockers makes it: its segments within r of p, its origin
// just off p, margins of a few ulps at these coordinates.
BlockerQuery QueryAround(const Vec3& p, float r) {
    BlockerQuery bq;
    bq.lo = p - Vec3(r), bq.hi = p + Vec3(r), bq.o = p + Vec3(0, 1e-3f, 0);
    bq.margin = 1e-5f, bq.far = r + 2e-5f, bq.reach = r, bq.delta8 = 2e-5f;
    return bq;
}

bool SameBits(float a, float b) { return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b); }

// The vectorised passes over a front list decide exactly as their scalar oracles: a point's
// blockers array by array, bit for bit (so the culling that reads them cannot tell which
// pass built them), the patch test and the culling answer by answer.
TEST(LightMeshKernels, VectorisedPassesEqualTheScalarOnesBitForBit) {
    if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "no AVX2 on this processor: only the scalar passes run";
    std::mt19937 rng(20261202);
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f), reach(0.2f, 1.5f);
    const FindBlockersFunction scalarBlockers = ChooseFindBlockersFunction(1), wideBlockers = ChooseFindBlockersFunction(8);
    const PatchSeesFunction scalarPatch = ChoosePatchSeesFunction(1), widePatch = ChoosePatchSeesFunction(8);
    const CullFunction sseCull = ChooseCullFunction(4), wideCull = ChooseCullFunction(8);
    ASSERT_NE(scalarBlockers, wideBlockers);
    ASSERT_NE(scalarPatch, widePatch);
    uint64_t kept = 0, sees = 0, decided = 0, queries = 0;
    for (uint32_t count : {1u, 7u, 8u, 9u, 40u, 200u}) {
        const FrontArrays f = RandomFrontList(rng, count);
        for (int q = 0; q < 300; ++q) {
            const Vec3 p(coord(rng), coord(rng), coord(rng));
            const float r = reach(rng);
            const BlockerQuery bq = QueryAround(p, r);
            Blockers a, b;
            const bool okA = scalarBlockers(f, bq, &a), okB = wideBlockers(f, bq, &b);
            ASSERT_EQ(okA, okB);
            if (!okA) continue;
            ASSERT_EQ(a.count, b.count);
            kept += a.count;
            const float* arraysA[] = {a.nx, a.ny, a.nz, a.d, a.side, a.c0x, a.c0y, a.c0z, a.c1x,
                                      a.c1y, a.c1z, a.c2x, a.c2y, a.c2z, a.m0, a.m1, a.m2};
            const float* arraysB[] = {b.nx, b.ny, b.nz, b.d, b.side, b.c0x, b.c0y, b.c0z, b.c1x,
                                      b.c1y, b.c1z, b.c2x, b.c2y, b.c2z, b.m0, b.m1, b.m2};
            for (int k = 0; k < 17; ++k)
                for (uint32_t i = 0; i < a.count; ++i) ASSERT_TRUE(SameBits(arraysA[k][i], arraysB[k][i])) << k << " " << i;
            for (uint32_t i = 0; i < a.count; ++i) ASSERT_EQ(a.reaches[i], b.reaches[i]) << i;
            FinishBlockers(&a);
            FinishBlockers(&b);
            for (uint32_t g = 0; g * kCullWidth < a.count; ++g) ASSERT_EQ(a.octants[g], b.octants[g]) << g;
            for (int s = 0; s < 8; ++s) {
                const Vec3 x = p + Vec3(coord(rng), coord(rng), coord(rng)) * (r / 2);
                const int c4 = sseCull(a, x, bq.o, bq.margin), c8 = wideCull(a, x, bq.o, bq.margin);
                ASSERT_EQ(c4, c8);
                decided += c8 >= 0;
                PatchQuery pq;
                pq.x = x, pq.lo = Min(x, p - Vec3(0.1f)), pq.hi = Max(x, p + Vec3(0.1f)), pq.m = 1e-5f, pq.mQ = 2e-5f;
                const bool s1 = scalarPatch(f, pq), s8 = widePatch(f, pq);
                ASSERT_EQ(s1, s8);
                sees += s8;
                ++queries;
            }
        }
    }
    // The cases are not all alike: blockers were kept, segments decided, patches seen and not.
    EXPECT_GT(kept, 0u);
    EXPECT_GT(decided, 0u);
    EXPECT_GT(sees, 0u);
    EXPECT_LT(sees, queries);
}

// The culling's answer is the one a blocker-by-blocker reading of its rule gives: 1 if some
// blocker is certainly hit (the ends on both sides of its plane, the line inside its three
// edges), else -1 if some blocker is not certainly missed, else 0. The SSE and AVX2 widths
// share one template, so this oracle, written out apart (the same float expressions in the
// same order), is what checks the early stop at a hit and the lanes' reduction.
int CullOracle(const Blockers& b, const Vec3& x, const Vec3& o, float m) {
    const Vec3 d = x - o;
    bool maybe = false;
    for (uint32_t i = 0; i < b.count; ++i) {
        // A blocker that does not reach to the side d points to, on some axis, is missed.
        bool reached = true;
        for (int a = 0; a < 3; ++a) reached = reached && ((b.reaches[i] >> (2 * a + (d[a] < 0 ? 1 : 0))) & 1);
        if (!reached) continue;
        const float side = (b.nx[i] * x.x + b.ny[i] * x.y + b.nz[i] * x.z - b.d[i]) * b.side[i];
        const bool sameSide = side > m, across = side < -m;
        const float t0 = b.c0x[i] * d.x + b.c0y[i] * d.y + b.c0z[i] * d.z;
        const float t1 = b.c1x[i] * d.x + b.c1y[i] * d.y + b.c1z[i] * d.z;
        const float t2 = b.c2x[i] * d.x + b.c2y[i] * d.y + b.c2z[i] * d.z;
        const bool pos0 = t0 > b.m0[i], pos1 = t1 > b.m1[i], pos2 = t2 > b.m2[i];
        const bool neg0 = t0 < -b.m0[i], neg1 = t1 < -b.m1[i], neg2 = t2 < -b.m2[i];
        const bool outside = (pos0 || pos1 || pos2) && (neg0 || neg1 || neg2);
        const bool inside = (pos0 && pos1 && pos2) || (neg0 && neg1 && neg2);
        if (inside && across) return 1;
        maybe = maybe || !(sameSide || outside);
    }
    return maybe ? -1 : 0;
}

// A blocker's direction code says on which sides of the origin its box reaches (within the
// margin), and the eights' octants are the union of their blockers' octants: checked
// against the front list's boxes directly, for origins on random front triangles' box
// faces too (where the margin decides).
TEST(LightMeshKernels, DirectionCodesFollowTheBlockersBoxes) {
    std::mt19937 rng(20261204);
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f), reach(0.2f, 1.5f);
    uint64_t reachedBoth = 0, reachedOne = 0;
    for (int width : {1, 8}) {
        const FindBlockersFunction findBlockers = ChooseFindBlockersFunction(width);
        for (int q = 0; q < 200; ++q) {
            const FrontArrays f = RandomFrontList(rng, 40);
            BlockerQuery bq;
            Vec3 p(coord(rng), coord(rng), coord(rng));
            const float r = reach(rng);
            bq.margin = 1e-5f, bq.far = 10, bq.reach = r, bq.delta8 = 2e-5f;
            if (q % 4 == 0) {  // on box faces, no margin: the comparisons' ties decide
                const uint32_t t = static_cast<uint32_t>(q) % 40;
                p = q % 8 == 0 ? Vec3(f.hix[t], f.hiy[t], f.hiz[t]) : Vec3(f.lox[t], f.loy[t], f.loz[t]);
                bq.margin = 0;
            }
            bq.lo = p - Vec3(r), bq.hi = p + Vec3(r), bq.o = p;
            Blockers b;
            if (!findBlockers(f, bq, &b)) continue;
            FinishBlockers(&b);
            // Blockers keep the front list's order: match them by their planes.
            uint32_t i = 0;
            for (uint32_t n = 0; n < b.count; ++n) {
                while (i < f.count && !(SameBits(f.nx[i], b.nx[n]) && SameBits(f.d[i], b.d[n]))) ++i;
                ASSERT_LT(i, f.count);
                const float lo[3] = {f.lox[i], f.loy[i], f.loz[i]}, hi[3] = {f.hix[i], f.hiy[i], f.hiz[i]};
                for (int a = 0; a < 3; ++a) {
                    const bool plus = hi[a] >= bq.o[a] - bq.margin, minus = lo[a] <= bq.o[a] + bq.margin;
                    ASSERT_EQ(((b.reaches[n] >> (2 * a)) & 1) != 0, plus) << width << " " << q << " " << n << " " << a;
                    ASSERT_EQ(((b.reaches[n] >> (2 * a + 1)) & 1) != 0, minus) << width << " " << q << " " << n << " " << a;
                    reachedBoth += plus && minus;
                    reachedOne += plus != minus;
                }
                ++i;
            }
            for (uint32_t g = 0; g * kCullWidth < b.count; ++g)
                for (int k = 0; k < 8; ++k) {
                    bool any = false;
                    for (uint32_t n = g * kCullWidth; n < std::min(b.count, (g + 1) * kCullWidth); ++n) {
                        bool met = true;
                        for (int a = 0; a < 3; ++a) met = met && ((b.reaches[n] >> (2 * a + ((k >> a) & 1))) & 1);
                        any = any || met;
                    }
                    ASSERT_EQ(((b.octants[g] >> k) & 1) != 0, any) << width << " " << q << " " << g << " " << k;
                }
        }
    }
    EXPECT_GT(reachedBoth, 0u);
    EXPECT_GT(reachedOne, 0u);
}

TEST(LightMeshKernels, CullingEqualsTheBlockerByBlockerRule) {
    std::mt19937 rng(20261203);
    std::uniform_real_distribution<float> coord(-2.0f, 2.0f), reach(0.2f, 1.5f);
    const FindBlockersFunction findBlockers = ChooseFindBlockersFunction(1);
    const CullFunction cull4 = ChooseCullFunction(4), cull8 = ChooseCullFunction(8);
    uint64_t answers[3] = {0, 0, 0};  // undecided, unblocked, blocked
    for (uint32_t count : {1u, 7u, 8u, 9u, 40u, 200u}) {
        const FrontArrays f = RandomFrontList(rng, count);
        for (int q = 0; q < 300; ++q) {
            const Vec3 p(coord(rng), coord(rng), coord(rng));
            const float r = reach(rng);
            const BlockerQuery bq = QueryAround(p, r);
            Blockers b;
            if (!findBlockers(f, bq, &b)) continue;
            FinishBlockers(&b);
            for (int s = 0; s < 8; ++s) {
                const Vec3 x = p + Vec3(coord(rng), coord(rng), coord(rng)) * (r / 2);
                const int want = CullOracle(b, x, bq.o, bq.margin);
                ASSERT_EQ(cull4(b, x, bq.o, bq.margin), want) << count << " " << q << " " << s;
                ASSERT_EQ(cull8(b, x, bq.o, bq.margin), want) << count << " " << q << " " << s;
                ++answers[want + 1];
            }
        }
    }
    // All three answers occur, so each path of the loop ran.
    EXPECT_GT(answers[0], 0u);
    EXPECT_GT(answers[1], 0u);
    EXPECT_GT(answers[2], 0u);
}

}  // namespace
}  // namespace light_mesh_kernels_test
}  // namespace lm::kernels
