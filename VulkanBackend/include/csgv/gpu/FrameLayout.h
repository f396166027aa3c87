// SPDX-License-Identifier: MIT
/// @file FrameLayout.h
/// @brief The frame pipeline's contract between Renderer.cpp and the shaders (render_common.glsl
/// and the passes that include it), written once: valid C++ and GLSL (csgv/base/GlslShim.h).
/// The frame parameter block, the material records, the address slots, the flags, the cache
/// counter words and the resolve passes. The shader compiler embeds this file, so changing a
/// value here changes both sides; Renderer.cpp's static_asserts hold the struct sizes to std430.
#ifndef CSGV_GPU_FRAME_LAYOUT_H
#define CSGV_GPU_FRAME_LAYOUT_H

#include "csgv/base/GlslShim.h"

CSGV_NAMESPACE_BEGIN(csgv::gpu)

/// "Nothing": no cache region, no material, no pixel, no label.
CSGV_CONST(uint32_t, kNone, 0xFFFFFFFFu)

// Frame flags (Frame.frame.y).
CSGV_CONST(uint32_t, kFlagJitter, 1u)
CSGV_CONST(uint32_t, kFlagFinest, 2u)
CSGV_CONST(uint32_t, kFlagDenoise, 4u)
CSGV_CONST(uint32_t, kFlagLimitRequests, 8u)
CSGV_CONST(uint32_t, kFlagDepthInput, 16u)
CSGV_CONST(uint32_t, kFlagLabelMap, 64u)
CSGV_CONST(uint32_t, kFlagResolveInRender, 128u) ///< the render pass writes the output and the counts itself (no gather follows)
CSGV_CONST(uint32_t, kFlagVisibilityChanged, 256u) ///< brick visibility (kSlotVisible) changed: the request stage visits every brick
CSGV_CONST(uint32_t, kFlagPrefetch, 512u) ///< the request stage asks for every visible brick not cached, used or not
CSGV_CONST(uint32_t, kFlagListNext, 1024u) ///< PIXEL_LIST: the render pass lists the cells left below the sample target for the next frame (kAllocNextCount)
CSGV_CONST(uint32_t, kFlagGatherInRender, 2048u) ///< the render pass writes what the gather would (kSlotDenoiseA, counts) for the cells it takes; no gather follows, the denoising passes do

// Shading modes (render.comp's SHADING): the values of csgv::gpu::Shading.
CSGV_CONST(uint32_t, kShadingLocal, 0u)
CSGV_CONST(uint32_t, kShadingShadow, 1u)
CSGV_CONST(uint32_t, kShadingAo, 2u)
CSGV_CONST(uint32_t, kShadingPt, 3u)

// Colour modes (GpuMaterial.select.w).
CSGV_CONST(uint32_t, kColorConstant, 0u)
CSGV_CONST(uint32_t, kColorColormap, 1u)
CSGV_CONST(uint32_t, kColorRandom, 2u)

/// In a G-buffer entry's second word: the entry holds a sample's first hit (a cleared entry is all 0).
CSGV_CONST(uint32_t, kGBufferSampled, 0x100u)
/// ... or: the pixel has no sample yet and its accumulation word holds a preview (render.comp),
/// shown until its first sample replaces it.
CSGV_CONST(uint32_t, kGBufferPreview, 0x200u)
/// ... and: the hit is the first semi-transparent surface, the ray having met no opaque one (a
/// pick names what the pixel shows, also in a volume of translucent materials only).
CSGV_CONST(uint32_t, kGBufferTranslucent, 0x400u)
/// ... and from this bit up: the pixel's valid samples (0 in a cleared entry, as in a preview's),
/// written with every sample's first hit: one store, no buffer of counts to fill. A pixel takes
/// no more than kGBufferCountMax (render_common.glsl's wantsSample).
CSGV_CONST(uint32_t, kGBufferCountShift, 11u)
CSGV_CONST(uint32_t, kGBufferCountMax, 0x1FFFFFu)
/// ... and in its bits 3-7: the accumulation it belongs to, 1..kGBufferEpochs (Frame frame.z).
/// An entry of another reads as cleared (all 0): a new accumulation fills the G-buffer only when
/// the epochs wrap (and when it is new), not at every camera move.
CSGV_CONST(uint32_t, kGBufferEpochShift, 3u)
CSGV_CONST(uint32_t, kGBufferEpochMask, 0x1Fu)
CSGV_CONST(uint32_t, kGBufferEpochs, 31u)
/// An output depth word (kSlotOutput) is the depth's float bits ^ this (the bits of 1.0f), so a
/// zero fill clears colour and depth together: no surface, depth 1 (the far plane).
CSGV_CONST(uint32_t, kOutputDepthXor, 0x3F800000u)

// How render_common.glsl's materialOf finds a stored label's material (its define LABEL_LOOKUP,
// chosen per renderer: LabelLookup.h).
CSGV_CONST(uint32_t, kLookupScan, 0u)   ///< a table for labels below Frame.counts.w, the material list for the others
CSGV_CONST(uint32_t, kLookupDense, 1u)  ///< a table label -> material covers every stored label

// Buffer addresses in Frame.addr.
CSGV_CONST(uint32_t, kSlotBricks, 0u)         ///< uvec4 per brick: cache word offset, cached lod (kNone), frame+1 of last use, visible
CSGV_CONST(uint32_t, kSlotCache, 1u)          ///< decoded labels
CSGV_CONST(uint32_t, kSlotAlloc, 2u)          ///< the kAlloc* words below
CSGV_CONST(uint32_t, kSlotFree, 3u)           ///< LEVELS free stacks of brickCount words each
CSGV_CONST(uint32_t, kSlotRequests, 4u)       ///< 2 words per request: brick, lod
CSGV_CONST(uint32_t, kSlotDecodes, 5u)        ///< 3 words per decode: brick, inverse level, cache offset
CSGV_CONST(uint32_t, kSlotAccum, 6u)          ///< vec4 per pixel: sum of premultiplied samples
CSGV_CONST(uint32_t, kSlotGBuffer, 7u)        ///< uvec4 per pixel: label, face | kGBufferSampled | samples << kGBufferCountShift, window depth bits, distance bits: the first sample's hit, the count the latest (all 0, or of another epoch: no sample; kGBufferEpochShift)
CSGV_CONST(uint32_t, kSlotDepthIn, 8u)        ///< float per pixel: window depth of opaque geometry
CSGV_CONST(uint32_t, kSlotMaterials, 9u)      ///< GpuMaterial array
CSGV_CONST(uint32_t, kSlotColormaps, 10u)     ///< vec4 colour samples
CSGV_CONST(uint32_t, kSlotAttributes, 11u)    ///< uint64 address per attribute: float per label
CSGV_CONST(uint32_t, kSlotOutput, 12u)        ///< two words per pixel, one 64-bit store: resolved premultiplied RGBA, 8 bits a channel (packUnorm4x8, R lowest: what a view's colour buffer holds), then the window depth of the first surface as its float bits ^ kOutputDepthXor
CSGV_CONST(uint32_t, kSlotLabelMap, 13u)      ///< uint per stored label: the original label
CSGV_CONST(uint32_t, kSlotDenoiseA, 14u)      ///< vec4 per pixel: resolve ping-pong buffers
CSGV_CONST(uint32_t, kSlotDenoiseB, 15u)
CSGV_CONST(uint32_t, kSlotVisible, 16u)       ///< uvec2 per brick: its preview label (the root label, else the first palette entry with a material) and that material, kNone twice when no palette entry has one (host, per materials)
CSGV_CONST(uint32_t, kSlotArrays, 17u)        ///< the encoding: uint64 address per array (cache paletting reads palettes)
CSGV_CONST(uint32_t, kSlotStarts, 18u)        ///< the encoding: brick start words
CSGV_CONST(uint32_t, kSlotBlueNoise, 19u)     ///< 64x64 bytes of blue noise, four to a uint
CSGV_CONST(uint32_t, kSlotMaterialTable, 20u) ///< label -> material (kNone): uint per stored label up to the largest (LabelLookup.h)
CSGV_CONST(uint32_t, kSlotUniform, 21u)       ///< uvec2 per brick: its uniform sub-blocks (Layout.h) when cached at the finest level
CSGV_CONST(uint32_t, kSlotDetail, 22u)        ///< detail streaming: uvec2 per brick, its finest-level stream in the detail buffer (word offset, kNone when absent; words) (DetailStream.h)
CSGV_CONST(uint32_t, kSlotDetailRequests, 23u) ///< detail streaming: bricks whose finest-level stream a frame wanted and did not find (count in kAllocDetailRequests)
CSGV_CONST(uint32_t, kSlotGhost, 24u)         ///< an MPI rank's piece (Renderer::setGhostFaces): kGhostHeaderWords words (piece box lo, hi in voxels; word offset of each side's labels, 0 for none), then the labels just outside each side; 0 when not a piece
CSGV_CONST(uint32_t, kSlotCoarse, 25u)        ///< an MPI rank's piece (Renderer::setCoarseStandIns): the whole volume's stored labels at levels c..LEVELS-1 (what secondary rays see of other ranks' bricks): words c, n = LEVELS - c, u (1: each label word carries its node's uniform level above kUniformLevelShift, csgv::gridUniformLevels, where every label is below it; kNone stays), then per level kCoarseLevelWords (word offset of its labels, x fastest; its dimensions); 0 when none
CSGV_CONST(uint32_t, kSlotLabelColors, 26u)   ///< vec4 per entry of kSlotMaterialTable (kLookupDense): the label's colour and opacity under its material (label_colors.comp)
CSGV_CONST(uint32_t, kSlotPixelList, 27u)     ///< PIXEL_LIST (CPU devices): uint per listed cell of the footprint grid (x | y << 16) whose pixel takes a sample this frame (pixel_list.comp); from word width * height on, the cells the render pass leaves below the target (kFlagListNext)
CSGV_CONST(uint32_t, kSlotHidden, 28u)       ///< uvec2 per brick cached at a level whose nodes are no larger than a sub-block: its sub-blocks (Layout.h) inside the volume that hold no label a material draws at that level (cache_hidden.comp); all 0 where the volume holds one undrawn label at most (such sub-blocks are uniform)
CSGV_CONST(uint32_t, kSlotEmptyGroups, 29u)  ///< uint per brick a material draws nothing of: the largest g such that its aligned group of 2^g bricks a side holds no brick a material draws nor another rank's (csgv/codec/BrickGroups.h, host, per materials); march() steps over the group whole
CSGV_CONST(uint32_t, kSlotCount, 30u)
CSGV_CONST(uint32_t, kGhostHeaderWords, 12u)
CSGV_CONST(uint32_t, kCoarseHeaderWords, 3u)
CSGV_CONST(uint32_t, kCoarseLevelWords, 4u)

/// Brick table word w (kSlotBricks): 0 invisible, 1 visible, kBrickStandIn visible and cached at
/// the next coarser level than the view wants, because its finest-level stream has not arrived
/// (detail streaming): exact rays treat it as missing, previews and deep bounces sample it.
CSGV_CONST(uint32_t, kBrickStandIn, 2u)
/// Another MPI rank's brick (GpuVolume::owns): view rays pass it (that rank draws it), secondary
/// rays see it at its level of detail, or the finest level kSlotCoarse holds when that is coarser. kSlotVisible marks it {kNone, kBrickAbsent}.
CSGV_CONST(uint32_t, kBrickAbsent, 3u)
/// CARRY_DECODES: the brick table (kSlotBricks) is followed by a word per brick, the progress of
/// its decoding while it carries over frames (a region, no level yet): kInFlightValid | k << 8 |
/// l, where the region is laid out for level l (decode_bricks.comp: a node's label in the last
/// word of its Morton range) and the nodes of edge 2^k (finest voxels, k > l) are complete; 0
/// before its first level is. Previews read such a brick there (IN_FLIGHT_PREVIEWS); cache_assign
/// clears the word when it gives the brick a region.
CSGV_CONST(uint32_t, kInFlightValid, 0x80000000u)
CSGV_CONST(uint32_t, kBrickEntryWords, 4u) ///< kSlotBricks: a uvec4 a brick
/// Where the in-flight words begin: bytes after the brick table's address (the host sizes the
/// table by it, decode_bricks.comp and the render pass find the words by it).
CSGV_FN uint64_t inFlightWordsOffset(uint32_t brickCount) { return uint64_t(4u * kBrickEntryWords) * uint64_t(brickCount); }

// Words of the cache counter buffer (kSlotAlloc), read by the host between frames.
CSGV_CONST(uint32_t, kAllocTop, 0u)          ///< cache words handed out from the top
CSGV_CONST(uint32_t, kAllocCapacity, 1u)     ///< cache words
CSGV_CONST(uint32_t, kAllocFull, 2u)         ///< set when a request found no space
CSGV_CONST(uint32_t, kAllocDecodes, 3u)      ///< decode requests this frame (read by the decode passes)
CSGV_CONST(uint32_t, kAllocRequests, 4u)     ///< requests this frame
CSGV_CONST(uint32_t, kAllocMinSamples, 5u)   ///< smallest sample count of any pixel after this frame
CSGV_CONST(uint32_t, kAllocNewSamples, 6u)   ///< pixels that gained a sample this frame
CSGV_CONST(uint32_t, kAllocMissing, 7u)      ///< pixels whose ray met a brick not in the cache
CSGV_CONST(uint32_t, kAllocMinRow, 8u)       ///< first pixel (row-major) with the previous minimum sample count
CSGV_CONST(uint32_t, kAllocPrevMin, 9u)      ///< previous frame's minimum sample count (host-written)
CSGV_CONST(uint32_t, kAllocHoles, 10u)       ///< pixels the resolve left empty (no sample of their own or of their stride block)
CSGV_CONST(uint32_t, kAllocPreviews, 12u)     ///< pixels that show a preview (no sample of their own or of their stride block yet)
CSGV_CONST(uint32_t, kAllocEvictAge, 11u)    ///< host-written: evict cached bricks no ray used for this many frames (0: none)
CSGV_CONST(uint32_t, kAllocDetailRequests, 13u) ///< entries written to kSlotDetailRequests this frame (may pass the list's length)
CSGV_CONST(uint32_t, kAllocListCount, 14u)   ///< cells in kSlotPixelList this frame (host-zeroed; read back to size the render pass)
CSGV_CONST(uint32_t, kAllocNextCount, 15u)   ///< kFlagListNext: cells the render pass listed for the next frame (host-zeroed)
CSGV_CONST(uint32_t, kAllocFreeCount, 16u)   ///< + lod
CSGV_CONST(uint32_t, kAllocReqCount, 24u)    ///< + lod
CSGV_CONST(uint32_t, kAllocPops, 32u)        ///< + lod
CSGV_CONST(uint32_t, kAllocProvBase, 40u)    ///< + lod
CSGV_CONST(uint32_t, kAllocProvCount, 48u)   ///< + lod
CSGV_CONST(uint32_t, kAllocNextKept, 56u)    ///< kFlagListNext: fewest samples of the cells the next frame's list leaves out (kNone: none)
CSGV_CONST(uint32_t, kAllocCarry, 57u)      ///< CARRY_DECODES: decodes the frame's last decode dispatch left unfinished (overlapped: and those that ended, unpublished), moved to the other decode list for the next frame
CSGV_CONST(uint32_t, kAllocCarried, 58u)    ///< CARRY_DECODES: this frame's decodes carried from the previous frame (its list's first entries)
CSGV_CONST(uint32_t, kAllocCarryEnded, 59u)   ///< overlapped decodes: of kAllocCarry, those that ended (the next frame publishes them, decoding nothing)
CSGV_CONST(uint32_t, kAllocCarriedEnded, 60u) ///< overlapped decodes: of kAllocCarried, those that ended (published by this frame's first dispatch, not decoded)
CSGV_CONST(uint32_t, kAllocWords, 61u)

// Workgroup sizes (the shaders' local_size, the host's group counts).
CSGV_CONST(uint32_t, kGroupBricks, 64u)  ///< cache_request.comp (per brick), cache_assign.comp (per request)
CSGV_CONST(uint32_t, kGroupDecodes, 32u) ///< decode_bricks.comp (per decode) on CPU devices; GPUs take one (GpuVolume.cpp decodeGroup)
CSGV_CONST(uint32_t, kGroupTile, 16u)    ///< render.comp and resolve.comp: kGroupTile^2 invocations of PIXEL_BLOCK^2 pixels
CSGV_CONST(uint32_t, kGroupList, 64u)    ///< pixel_list.comp: invocations a group, each taking kListBlock cells
CSGV_CONST(uint32_t, kListBlock, 16u)
CSGV_CONST(uint32_t, kListLanes, 8u)     ///< PIXEL_LIST: consecutive invocations CPU devices run as one SIMD group, taking consecutive list entries (render.comp listIndex; the host's tiles, Renderer.cpp kListTile)
CSGV_CONST(uint32_t, kOutlineRowWords, 8u) ///< ResolvePush::spans: words a row (a span of two words for each resolve pass)
CSGV_CONST(uint32_t, kGroupLabels, 64u)  ///< label_colors.comp
CSGV_CONST(uint32_t, kHiddenGroupBricks, 16u) ///< cache_hidden.comp over the whole brick table (HIDDEN_ALL): bricks a group takes in turn

// Texel buffer bindings (set 0) of the render pass (RENDER_TEXELS, render_common.glsl; R32_UINT
// views) and of the resolve passes (RESOLVE_TEXELS, resolve.comp; R32G32B32A32_UINT views, a
// pixel's 16 bytes a texel): Renderer.cpp views the buffers in this order.
CSGV_CONST(uint32_t, kTexelCache, 0u)         ///< kSlotCache
CSGV_CONST(uint32_t, kTexelBricks, 1u)        ///< kSlotBricks
CSGV_CONST(uint32_t, kTexelUniform, 2u)       ///< kSlotUniform
CSGV_CONST(uint32_t, kTexelMaterialTable, 3u) ///< kSlotMaterialTable
CSGV_CONST(uint32_t, kTexelLabelColors, 4u)   ///< kSlotLabelColors
CSGV_CONST(uint32_t, kTexelGBuffer, 5u)       ///< kSlotGBuffer (the sample counts in its second words)
CSGV_CONST(uint32_t, kTexelPixelList, 6u)     ///< kSlotPixelList
CSGV_CONST(uint32_t, kTexelMaterials, 7u)     ///< kSlotMaterials
CSGV_CONST(uint32_t, kTexelLabelMap, 8u)      ///< kSlotLabelMap
CSGV_CONST(uint32_t, kTexelDepthIn, 9u)       ///< kSlotDepthIn
CSGV_CONST(uint32_t, kTexelBlueNoise, 10u)    ///< kSlotBlueNoise
CSGV_CONST(uint32_t, kTexelVisible, 11u)      ///< kSlotVisible
CSGV_CONST(uint32_t, kTexelHidden, 12u)       ///< kSlotHidden
CSGV_CONST(uint32_t, kTexelEmptyGroups, 13u)  ///< kSlotEmptyGroups
CSGV_CONST(uint32_t, kTexelOutput, 14u)       ///< kSlotOutput (render.comp's PREFETCH_OUTPUT: read early, never used)
CSGV_CONST(uint32_t, kRenderTexelCount, 15u)
CSGV_CONST(uint32_t, kResolveTexelGBuffer, 0u) ///< kSlotGBuffer
CSGV_CONST(uint32_t, kResolveTexelAccum, 1u)   ///< kSlotAccum
CSGV_CONST(uint32_t, kResolveTexelSource, 2u)  ///< the pass's source (kSlotDenoiseA or kSlotDenoiseB)
CSGV_CONST(uint32_t, kResolveTexelSpans, 3u)   ///< ResolvePush::spans' buffer (kOutlineRowWords a row: two texels)
CSGV_CONST(uint32_t, kResolveTexelCount, 4u)

// Passes of resolve.comp (its define RESOLVE_PASS: one pipeline per pass, for CPU devices run
// every branch a shader holds, taken or not).
CSGV_CONST(uint32_t, kResolveGather, 0u)  ///< average and upsampling (tone-mapped when not denoising)
CSGV_CONST(uint32_t, kResolveAtrous1, 1u) ///< A-trous denoising, step 1 (then 2 and 4: passes 2 and 3)
CSGV_CONST(uint32_t, kResolveAtrous2, 2u)
CSGV_CONST(uint32_t, kResolveAtrous4, 3u) ///< the last: tone-mapped straight into the output
// Where a resolve pass writes (its define RESOLVE_OUTPUT): the output, a denoising buffer, or
// either (the push constant's dst).
CSGV_CONST(uint32_t, kResolveToBuffer, 0u)
CSGV_CONST(uint32_t, kResolveToOutput, 1u)
CSGV_CONST(uint32_t, kResolveToEither, 2u)

// The GPU decoder's lists (GpuVolume.cpp, cache_assign.comp, decode_bricks.comp, host decoding).
CSGV_CONST(uint32_t, kDecodeEntryWords, 3u)  ///< per decode: brick, inverse level, cache word offset
CSGV_CONST(uint32_t, kDecodeStateWords, 12u) ///< per decode: the decoder state saved between dispatches
CSGV_CONST(uint32_t, kDecodeStateStatus, 8u) ///< its word holding the result (kDecodeOk, ...)
CSGV_CONST(uint32_t, kDecodeParamWords, 10u) ///< per dispatch: count (unused in frames), steps, first, then kDecodeParam*
/// Words of a dispatch's parameters (host-visible) where decode_bricks.comp reports the decodes
/// that failed in it (drawn empty): how many, the first one's brick + 1 and its result code.
CSGV_CONST(uint32_t, kDecodeParamFailures, 3u)
CSGV_CONST(uint32_t, kDecodeParamFailedBrick, 4u)
CSGV_CONST(uint32_t, kDecodeParamFailedCode, 5u)
/// Word of a frame's decode dispatch parameters: 1 in the frame's last decode dispatch where
/// decodes carry over frames (RendererOptions::decodeStepsPerFrame): it moves those still running
/// (kDecodeParamDefer: and those that ended) to the other decode list (DecodePush::next), their
/// states too, for the next frame.
CSGV_CONST(uint32_t, kDecodeParamCarry, 6u)
/// Word of a frame's decode dispatch parameters: 1 where a failed decode only marks its entry
/// (kDecodeEntryFailed on its inverse level) and cache_uniform.comp fills its region, 64
/// invocations to a brick: one invocation filling a region of 64^3 words (or 32^3 after many
/// steps) ran into llvmpipe's loop limit and left part of a bad brick's labels visible.
CSGV_CONST(uint32_t, kDecodeParamMarkFailed, 7u)
/// Words of a frame's decode dispatch parameters where the frame's render runs beside its decode
/// (an overlapped frame, RendererOptions::overlapDecodes: no barrier between them, so the render
/// must read nothing the decode writes, but previews of bricks in flight, which take a word either
/// before or after the decoder rewrites it: a label of its node either way, kNone read as the
/// brick's preview label). kDecodeParamDefer: 1 in its decode dispatch, where a
/// decode that ends is not published (its level) but moved, ended, to the next frame's list too.
/// kDecodeParamPublish: 1 in the dispatch that comes first in every frame of such a renderer,
/// before its request pass: it decodes nothing, it publishes the decodes the previous frame
/// carried (kAllocCarry) that ended (their level) and the progress of those still running
/// (kInFlightValid), read from their saved states.
CSGV_CONST(uint32_t, kDecodeParamDefer, 8u)
CSGV_CONST(uint32_t, kDecodeParamPublish, 9u)
CSGV_CONST(uint32_t, kDecodeEntryFailed, 0x80000000u) ///< on a decode entry's inverse level: its decoding failed
/// Decode result (besides csgv/codec/Layout.h's): the finest level of a separated volume was
/// requested but its stream is not in the detail buffer.
CSGV_CONST(uint32_t, kDecodeNoDetail, 9u)

/// Push constants of decode_bricks.comp: only addresses (lavapipe specialises shaders on
/// push-constant values used in loop conditions, recompiling for every new value).
#define CSGV_DECODE_PUSH_MEMBERS                                                                    \
    uint64_t arrays;   /* one device address per encoding array */                                  \
    uint64_t starts;   /* brick start words */                                                      \
    uint64_t requests; /* kDecodeEntryWords per decode */                                           \
    uint64_t cache;    /* the brick cache */                                                        \
    uint64_t states;   /* kDecodeStateWords per decode */                                           \
    uint64_t params;   /* kDecodeParamWords of this dispatch */                                     \
    uint64_t count;    /* the decode count in its first word (written by the GPU in frames) */   \
    uint64_t detail;   /* separated volumes: the detail table (kSlotDetail), else 0 */               \
    uint64_t ring;     /* separated volumes: the detail buffer, else 0 */                           \
    uint64_t alloc;    /* frames whose decodes carry over: the cache counters (kAllocCarry), else 0 */ \
    uint64_t bricks;   /* ... the brick table: a decode that ends sets its brick's level; the words after it, a running one's progress (kInFlightValid) */ \
    uint64_t next;     /* ... the next frame's decode list */                                       \
    uint64_t nextStates; /* ... and its states */

/// The frame parameter block (std430), one per frame: GLSL `Frame`, C++ `FrameParams`.
#define CSGV_FRAME_MEMBERS                                                                          \
    CSGV_MAT4(clipToIndex)     /* NDC -> index space */                                             \
    CSGV_MAT4(indexToClip)                                                                          \
    CSGV_MAT4(indexToWorld)                                                                         \
    CSGV_MAT4(worldToIndex)                                                                         \
    CSGV_VEC4(lightWorld)      /* xyz: towards the light (world, unit); w: light intensity */       \
    CSGV_VEC4(lightIndex)      /* xyz: towards the light (index space); w: ambient intensity */     \
    CSGV_VEC4(environment)     /* rgb: sky colour for misses and ambient light; w: AO radius */     \
    CSGV_VEC4(clipMin)         /* xyz: clip box minimum (voxels); w: level-of-detail bias */        \
    CSGV_VEC4(clipMax)         /* xyz: clip box maximum (voxels); w: pixel footprint factor */      \
    CSGV_VEC4(pixel)           /* x: 2/W, y: 2/H, z: upsampling block (pixels), w: shading blend */ \
    CSGV_VEC4(tone)            /* x: brightness, y: contrast, z: gamma, w: tone mapping (1) */      \
    CSGV_VEC4_ARRAY(faceNormals, 6) /* world normals of the faces -x, +x, -y, +y, -z, +z */         \
    CSGV_UVEC4(frame)          /* x: frame index, y: flags, z: G-buffer epoch, w: sample target */  \
    CSGV_UVEC4(image)          /* x: W, y: H, z: subsampling stride, w: subsampling phase */        \
    CSGV_UVEC4(limits)         /* x: max requests, y/z: pixels [y, z) that may request, w: bounces */ \
    CSGV_UVEC4(counts)         /* x: materials, y: bricks, z: labels with attributes, w: table size */ \
    CSGV_UVEC4(rect)           /* pixels [x, z) x [y, w) that can show the volume (x, y multiples of 8) */ \
    CSGV_UVEC4(drawn)          /* x/y: the stored labels [x, y] hold every one a material draws; zw: 0 (z keeps render.comp's PREFETCH_OUTPUT read) */ \
    uint64_t addr[kSlotCount];

/// One material as the shaders read it (std430, 80 bytes).
struct GpuMaterial {
    CSGV_UVEC4(select) // x: attribute (kNone = label), y: label min, z: label max, w: colour mode
    CSGV_VEC4(range)   // x/y: filter min/max (float attributes), z/w: colour min/max
    CSGV_VEC4(rgba)    // constant colour, opacity
    CSGV_UVEC4(colour) // x: colour attribute (kNone = label), y: wrap (1 repeat), z: colormap offset, w: samples (0: palette)
    CSGV_VEC4(extra)   // x: emission
};
/// GpuMaterial in 32-bit words (read as texels): its size and where the emission (extra.x) is.
CSGV_CONST(uint32_t, kMaterialWords, 20u)
CSGV_CONST(uint32_t, kMaterialEmissionWord, 16u)

/// Push constants of resolve.comp.
#define CSGV_RESOLVE_PUSH_MEMBERS                                                                   \
    uint64_t frame;                                                                                 \
    uint32_t src; /* address slot of the input colour */                                            \
    uint32_t dst; /* address slot of the output colour */                                           \
    /* Denoised frames with the box's outline (PIXEL_LIST, stride 1), 0 for none: per row of the */ \
    /* rectangle, the span of pixels [x0, x1) each pass takes, in pass order (two words each; */     \
    /* Renderer.cpp kResolveReach). The others keep the clear's output. */                          \
    uint64_t spans;

#ifdef __cplusplus
struct FrameParams {
    CSGV_FRAME_MEMBERS
};
// std430 offsets: mat4 64 bytes, vec4/uvec4 16, uint64 8, no padding in this order.
static_assert(offsetof(FrameParams, lightWorld) == 256 && offsetof(FrameParams, faceNormals) == 368 &&
                  offsetof(FrameParams, frame) == 464 && offsetof(FrameParams, rect) == 528 &&
                  offsetof(FrameParams, drawn) == 544 && offsetof(FrameParams, addr) == 560 &&
                  sizeof(FrameParams) == 560 + 8 * kSlotCount,
              "FrameParams must match std430's Frame block");
static_assert(offsetof(GpuMaterial, colour) == 48 && sizeof(GpuMaterial) == 80, "GpuMaterial must match std430");
static_assert(sizeof(GpuMaterial) == 4 * kMaterialWords && offsetof(GpuMaterial, extra) == 4 * kMaterialEmissionWord,
              "kMaterialWords and kMaterialEmissionWord must match GpuMaterial");
struct ResolvePush {
    CSGV_RESOLVE_PUSH_MEMBERS
};
static_assert(sizeof(ResolvePush) == 24, "ResolvePush must match resolve.comp's push constants");
struct DecodePush {
    CSGV_DECODE_PUSH_MEMBERS
};
static_assert(sizeof(DecodePush) == 104, "DecodePush must match decode_bricks.comp's push constants");
#endif

CSGV_NAMESPACE_END

#endif // CSGV_GPU_FRAME_LAYOUT_H
