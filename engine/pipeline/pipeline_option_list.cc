// The option keys of PipelineOptions: key, field, range, units and doc (DescribeOptions).
#include "engine/pipeline/pipeline_options.h"

#include <cmath>
#include <limits>

#include "common/files.h"
#include "engine/pipeline/option_table.h"

namespace dypho {

using option_table::kNone;
using option_table::Table;

PipelineOptions::PipelineOptions() {
  // The built-in sequence: small enough for the README's first command.
  synth.width = 320;
  synth.height = 240;
  synth.frames = 120;
  synth.num_walkers = 2;
  synth.max_coverage = 0.4;
  synth.seed = 3;
  masking.segmenter.kind = "auto";
  // Threaded runs: a local BA reaches the tracker the frame after its keyframe.
  tracker.local_ba.fixed_lag = 1;
  // ... and a loop closure (its detection and pose graph on the back-end
  // thread) 2 frames after its keyframe.
  tracker.loops.fixed_lag = 2;
  // Loop closure is on (tracker.loops.enabled): the Gaussian and dense maps
  // follow a closure (engine/pipeline/loop_response.h).
}

std::vector<OptionInfo> DescribeOptions(PipelineOptions* o) {
  Table t;
  const double inf = kNone;
  // Pipeline.
  t.Str("preset", &o->preset, {"synthetic", "tum", "bonn", "shore", "stereo"}, "the preset these options started from");
  t.Str("poses", &o->poses, {}, "orb (ORB tracker) | gt (dataset ground truth) | a TUM trajectory file");
  t.Num("rolling_shutter", &o->rolling_shutter, -1, 1, "s", "RGB rolling-shutter readout; -1 = auto (0.025 on TUM)");
  t.Num("first_frame", &o->first_frame, 0, inf, "frames", "first dataset frame used");
  t.Num("max_frames", &o->max_frames, 0, inf, "frames", "frames processed (0 = all)");
  t.Num("max_gap", &o->max_gap, 1e-3, inf, "s", "frames further apart restart the masks");
  t.Bool("sequential", &o->sequential, "mapping and detector on the tracking thread (deterministic)");
  t.Num("max_mask_age", &o->max_mask_age, 0, 1000, "frames",
        "threaded: detector masks at most this old, frames wait for late ones (0 = newest, timing-dependent)");
  t.Num("detector_look_ahead", &o->detector_look_ahead, 0, 1000, "frames",
        "recorded RGB-D: the detector gets frames this far ahead, its frames' masks are their own (0 = max_mask_age)");
  t.Num("max_render_age", &o->max_render_age, 0, 1000, "frames",
        "threaded: a map render reaches the frame this many frames after its request (0 = when it arrives)");
  t.Num("debug_detector_delay_ms", &o->debug_detector_delay_ms, 0, 60000, "ms", "test hook: detector thread sleeps per run");
  t.Num("debug_render_delay_ms", &o->debug_render_delay_ms, 0, 60000, "ms", "test hook: map-render thread sleeps per render");
  t.Num("debug_track_delay_ms", &o->debug_track_delay_ms, 0, 60000, "ms", "test hook: tracking thread sleeps per frame");
  t.Bool("realtime", &o->realtime, "replay at the dataset's timestamps, dropping frames as a live camera does");
  t.Num("realtime_speed", &o->realtime_speed, 1e-3, 100, "", "realtime: replay rate (1 = the dataset's own)");
  t.Bool("strict_frames", &o->strict_frames,
         "an unreadable frame ends the run (outputs written) instead of being skipped");
  t.Num("prefetch", &o->prefetch, 0, 8, "frames", "frames read ahead by the reader thread");
  t.Num("queue_capacity", &o->queue_capacity, 1, 1000, "keyframes",
        "waiting keyframes kept unpacked (more wait packed; none is dropped)");
  t.Num("waiting_memory_mb", &o->waiting_memory_mb, 1, inf, "MiB",
        "packed waiting keyframes in memory; more are spilled to OUT/.waiting_keyframes/");
  t.Num("min_iterations_when_behind", &o->min_iterations_when_behind, -1, 100000, "steps",
        "with keyframes waiting, cut a keyframe's optimisation after this many steps (-1 = never)");
  t.Num("opencv_threads", &o->opencv_threads, 0, 64, "", "OpenCV worker threads during the run (0 = OpenCV's default)");
  t.Num("masking_downscale", &o->masking_downscale, 1, 4, "", "masks computed at 1/n resolution (masking.* px stay full-image px)");
  t.Num("mapping_nice", &o->mapping_nice, 0, 19, "", "nice value of the mapping and map-render threads (0 = as tracking)");
  t.Bool("semantic", &o->semantic, "semantic mask from the detector (needs a model or PNG folder)");
  t.Bool("semantic_dataset_masks", &o->semantic_dataset_masks,
         "no model: the dataset's masks/ stand in for the detector (synthetic data)");
  t.Num("render_downscale", &o->render_downscale, 1, 8, "", "background depth rendered at 1/n resolution");
  t.Num("render_every", &o->render_every, 1, 1000, "frames", "ask for a map render (helper thread) every n frames");
  t.Str("background_prior", &o->background_prior, {"map", "frames"},
        "background model's prior: map renders, or earlier frames' depth (independent of the mapping thread)");
  FrameDepthPriorOptions& fp = o->frame_prior;
  t.Num("frame_prior.max_frames", &fp.max_frames, 1, 1000, "", "frames kept for the frames prior");
  t.Num("frame_prior.fuse", &fp.fuse, 1, 1000, "", "nearest kept frames warped into one prior");
  t.Num("frame_prior.min_agree", &fp.min_agree, 0, 999, "", "other warped frames that must confirm a prior depth");
  t.Num("frame_prior.tolerance_abs", &fp.tolerance_abs, 1e-6, inf, "m", "agreement tolerance abs + rel * z^2: abs");
  t.Num("frame_prior.tolerance_rel", &fp.tolerance_rel, 0, inf, "1/m", "... rel");
  t.Num("frame_prior.spacing", &fp.spacing, 0, inf, "", "pose distance [m + rotation_weight * rad] between kept frames");
  t.Num("frame_prior.rotation_weight", &fp.rotation_weight, 0, inf, "m/rad", "rotation's share of the pose distance");
  t.Num("frame_prior.mask_margin_px", &fp.mask_margin_px, 0, 50, "px", "kept depth removed this far around the mask (render px)");
  t.Num("epipolar_radius_px", &o->epipolar_radius_px, 0, 50, "px", "epipolar outliers mask a disc for the tracker");
  t.Bool("map_features", &o->map_features, "tracker features with depth densify the map");
  t.Bool("bootstrap_masks", &o->bootstrap_masks, "first frame's flow mask from the flow to the second frame");
  t.Bool("keyframe_detection", &o->keyframe_detection, "detector run again on keyframes with a carried mask");
  t.Bool("keyframe_detection_refine", &o->keyframe_detection_refine,
         "that fresh mask refined by the frame's background depth (pixels agreeing with it are static)");
  t.Str("map_flow_mask", &o->map_flow_mask, {"all", "confirmed", "none"},
        "flow-only mask pixels the map leaves out: all, confirmed (near movers the detector saw lately), none");
  t.Num("moving_memory.frames", &o->moving_memory.frames, 1, 10000, "frames", "how long the detector's movers are remembered");
  t.Num("moving_memory.radius_px", &o->moving_memory.radius_px, 0, 200, "px", "remembered points cover a disc this wide");
  t.Num("moving_memory.min_overlap", &o->moving_memory.min_overlap, 1e-6, 1, "",
        "fraction of a flow component they must cover to confirm it");
  t.Bool("moving_memory.remember_confirmed", &o->moving_memory.remember_confirmed,
         "confirmed flow components are remembered too (a mover followed by the flow alone)");
  t.Bool("sparse_stereo_tracking", &o->sparse_stereo_tracking,
         "stereo: the tracker's feature depths from sparse matching of the pair (the map keeps the dense depth)");
  t.Num("stereo_preview_downscale", &o->stereo_preview_downscale, 1, 8, "x",
        "stereo, sparse tracking: per-frame depth from the pair at 1/n size; dense depth for keyframes only (1 = every frame)");
  t.Bool("stereo_prior_tracking", &o->stereo_prior_tracking,
         "stereo with previews: the tracker's feature matches searched around the preview's disparity (no right-image features)");
  t.Num("iterations_per_keyframe", &o->iterations_per_keyframe, 0, 100000, "steps", "optimisation after each keyframe");
  t.Num("final_iterations", &o->final_iterations, 0, 1000000, "steps", "steps over all keyframes at the end");
  t.Num("loop_refine_iterations", &o->loop_refine_iterations, 0, 100000, "steps",
        "steps after a loop closure moved the keyframes");
  t.Num("finish_seconds", &o->finish_seconds, 0, inf, "s",
        "after the last frame: queue drained, then refinement until this long after it (0 = no limit)");
  t.Num("carve_votes", &o->carve_votes, 0, 1000, "keyframes",
        "after the last frame, remove Gaussians this many other keyframes see through (0 = off)");
  t.Num("holdout_every", &o->holdout_every, 0, inf, "frames",
        "keep every n-th non-keyframe to stop the final refinement when it converges (0 = off)");
  t.Num("max_holdout_frames", &o->max_holdout_frames, 1, 1000, "frames", "held-back frames kept");
  t.Num("finish_check_every", &o->finish_check_every, 1, 100000, "steps", "steps between held-back checks");
  t.Num("finish_tolerance", &o->finish_tolerance, 0, 1, "",
        "relative held-back improvement on the best so far below which the final refinement stops "
        "(finish_patience checks in a row)");
  t.Num("finish_patience", &o->finish_patience, 1, 1000, "checks",
        "held-back checks in a row without a gain of finish_tolerance that end the final refinement");
  t.Num("finish_min_steps_per_keyframe", &o->finish_min_steps_per_keyframe, 0, 100000, "steps",
        "the final refinement stops on the held-back frames only after this many steps per keyframe");
  t.Bool("write_keyframe_masks", &o->write_keyframe_masks,
         "each keyframe's final mask (what the map leaves out) as OUT/keyframe_masks/<timestamp>.png");
  t.Num("overlay_every", &o->overlay_every, 0, inf, "frames", "mask overlay JPEG every n frames (0 = none)");
  t.Num("keyframe_renders", &o->keyframe_renders, 0, 1000, "", "keyframes rendered beside the real image");
  t.Num("eval_every", &o->eval_every, 0, 100000, "frames", "map scored at every n-th frame (0 = not scored)");
  t.Num("eval_downscale", &o->eval_downscale, 1, 8, "", "PSNR/SSIM at 1/n resolution");
  t.Bool("write_splat", &o->write_splat, "write map.splat");
  t.Bool("write_glb", &o->write_glb, "write map.glb");
  t.Bool("write_spz", &o->write_spz, "write map.spz");
  t.Num("checkpoint_every", &o->checkpoint_every, 0, inf, "frames", "trajectory rewritten every n frames");

  // Keyframes.
  t.Num("keyframes.max_translation", &o->keyframes.max_translation, 0, inf, "m", "keyframe after this motion");
  t.Num("keyframes.max_rotation_deg", &o->keyframes.max_rotation_deg, 0, 180, "deg", "keyframe after this rotation");
  t.Num("keyframes.max_frame_gap", &o->keyframes.max_frame_gap, 1, inf, "frames", "keyframe at least every n frames");
  t.Num("keyframes.min_new_content", &o->keyframes.min_new_content, 0, 1, "",
        "keyframe when this fraction of the frame (its static pixels) is seen by no keyframe (0 = motion rules only)");
  t.Num("keyframes.sample_step_px", &o->keyframes.sample_step_px, 2, 64, "px", "depth sampling step of the content test");
  t.Num("keyframes.visibility_tolerance", &o->keyframes.visibility_tolerance, 1e-3, 0.999, "",
        "relative depth agreement of the content test (plus 2 cm)");
  t.Num("keyframes.sharpness_window", &o->keyframes.sharpness_window, 1, kMaxSharpnessWindow, "frames",
        "a due keyframe is the sharpest of this many frames");
  t.Num("keyframes.sharper_ratio", &o->keyframes.sharper_ratio, 0, inf, "",
        "keyframe when a frame is this many times sharper than the keyframes that see it (0 = off)");
  t.Num("keyframes.tail_new_content", &o->keyframes.tail_new_content, 0, 1, "",
        "at the end, the newest frame since the last keyframe seeing this fraction of new content is one (0 = off)");

  // Dense map.
  t.Bool("dense.enabled", &o->dense.enabled, "build the dense point-cloud map (dense.ply)");
  t.Num("dense.points.stride", &o->dense.points.stride, 1, 64, "px", "keyframe pixel grid step of the dense map");
  t.Num("dense.points.min_depth", &o->dense.points.min_depth, 0, inf, "m", "dense map: nearer depths are dropped");
  t.Num("dense.points.max_depth", &o->dense.points.max_depth, 1e-3, inf, "m", "dense map: farther depths are dropped");
  t.Num("dense.map.voxel_size", &o->dense.map.voxel_size, 1e-4, inf, "m", "dense map cell edge");

  // Seen-through keyframe pixels (engine/dynamic/seen_through.h).
  SeenThroughOptions& see = o->seen_through;
  t.Bool("seen_through.enabled", &see.enabled,
         "keyframe pixels that the frames around it see through are dynamic (keyframes wait for the frames after them)");
  t.Num("seen_through.window", &see.window, 1, 1000, "frames", "frames before and after a keyframe (its wait)");
  t.Num("seen_through.neighbours", &see.neighbours, 1, 2000, "frames", "frames of the window tested, evenly spread");
  t.Num("seen_through.votes", &see.votes, 1, 2000, "frames", "frames that must see through a pixel");
  t.Num("seen_through.downscale", &see.downscale, 1, 32, "x", "the neighbours' depth in blocks of n x n pixels (nearest)");
  t.Num("seen_through.margin_m", &see.margin_m, 0, inf, "m", "a neighbour sees through when this much farther ...");
  t.Num("seen_through.margin_rel", &see.margin_rel, 0, inf, "", "... or this fraction of the depth farther");
  t.Num("seen_through.dilate", &see.dilate, 0, 64, "blocks", "the seen-through mask grows by this much");
  t.Num("seen_through.edge_blocks", &see.edge_blocks, 0, 16, "blocks",
        "a neighbour's depth is its nearest within this many blocks (pose and rolling-shutter error at depth edges)");

  // Mapper.
  MapperOptions& m = o->mapper;
  t.Num("mapper.train_downscale", &m.train_downscale, 1, 8, "", "keyframes optimised at 1/n resolution");
  t.Num("mapper.sh_degree", &m.sh_degree, 0, 3, "", "SH degree of the map");
  t.Num("mapper.background", &m.background, 0, 1, "", "background grey level of renders");
  t.Num("mapper.insert_stride", &m.insert_stride, 1, 64, "px", "grid step of new Gaussians (training px)");
  t.Num("mapper.insert_alpha", &m.insert_alpha, 0, 1, "", "rendered alpha below which a pixel is unexplained");
  t.Num("mapper.insert_depth_ratio", &m.insert_depth_ratio, 0, 1, "", "observed depth this fraction in front: unexplained");
  t.Num("mapper.insert_scale_factor", &m.insert_scale_factor, 1e-3, 100, "", "initial std = factor * stride * depth / f");
  t.Num("mapper.insert_opacity", &m.insert_opacity, 1e-3, 0.999, "", "initial opacity");
  t.Bool("mapper.insert_without_depth", &m.insert_without_depth, "static pixels without depth get Gaussians");
  t.Num("mapper.min_depth", &m.min_depth, 0, inf, "m", "nearer depths are invalid");
  t.Num("mapper.max_depth", &m.max_depth, 1e-3, inf, "m", "farther depths are invalid");
  t.Num("mapper.lambda_ssim", &m.lambda_ssim, 0, 1, "", "weight of (1 - SSIM) in the colour term");
  t.Num("mapper.depth_weight", &m.depth_weight, 0, inf, "1/m", "weight of the depth L1 term");
  t.Num("mapper.window_size", &m.window_size, 1, 10000, "keyframes", "newest keyframes sampled by default");
  t.Num("mapper.older_keyframe_prob", &m.older_keyframe_prob, 0, 1, "", "probability of an older keyframe");
  t.Num("mapper.sharp_sampling_floor", &m.sharp_sampling_floor, 1e-3, 1, "",
        "final refinement draws blurred keyframes down to this weight (1 = uniform)");
  t.Num("mapper.refine_downscale", &m.refine_downscale, 0, 8, "",
        "final refinement at 1/n resolution (0 = as train_downscale)");
  t.Num("mapper.lr_means", &m.lr_means, 0, 1, "m/step", "Adam rate of the means");
  t.Num("mapper.lr_log_scales", &m.lr_log_scales, 0, 1, "", "Adam rate of the log-scales");
  t.Num("mapper.lr_quats", &m.lr_quats, 0, 1, "", "Adam rate of the quaternions");
  t.Num("mapper.lr_opacity", &m.lr_opacity, 0, 1, "", "Adam rate of the opacity logits");
  t.Num("mapper.lr_sh_dc", &m.lr_sh_dc, 0, 1, "", "Adam rate of the base colour");
  t.Num("mapper.lr_sh_rest", &m.lr_sh_rest, 0, 1, "", "Adam rate of the higher SH");
  t.Num("mapper.lr_pose_rotation", &m.lr_pose_rotation, 0, 1, "rad/step", "keyframe pose refinement rate");
  t.Num("mapper.lr_pose_translation", &m.lr_pose_translation, 0, 1, "m/step", "keyframe pose refinement rate");
  t.Bool("mapper.refine_poses", &m.refine_poses, "refine keyframe poses photometrically");
  t.Bool("map_sensor_model", &o->map_sensor_model,
         "mapper models rolling shutter (readout rolling_shutter) and blur (mapper.sensor.exposure)");
  t.Num("mapper.sensor.exposure", &m.sensor.exposure, 0, 1, "s", "exposure time of the blur model (map_sensor_model)");
  t.Num("mapper.sensor.max_samples", &m.sensor.max_samples, 1, 64, "", "most time samples of the blur model");
  t.Bool("mapper.refine_exposure", &m.refine_exposure, "learn a gain and bias per channel for each keyframe");
  t.Num("mapper.lr_exposure", &m.lr_exposure, 0, 1, "/step", "Adam rate of the per-keyframe gain and bias");
  t.Num("mapper.densify_every", &m.densify_every, 0, inf, "steps", "densify/prune period (0 = never)");
  t.Num("mapper.densify_grad_threshold", &m.densify_grad_threshold, 0, inf, "loss/ndc", "densification gradient (normalised device coordinates)");
  t.Num("mapper.densify_size_threshold", &m.densify_size_threshold, 0, inf, "m", "clone below, split above");
  t.Num("mapper.max_gaussians", &m.max_gaussians, 1, inf, "", "densification stops at this count");
  t.Num("mapper.prune_opacity", &m.prune_opacity, 0, 1, "", "Gaussians below this opacity are removed");
  t.Num("mapper.prune_max_scale", &m.prune_max_scale, 0, inf, "m", "Gaussians with a larger std are removed");
  t.Num("mapper.num_threads", &m.num_threads, 0, kMaxThreads, "threads", "mapping threads (0 = all)");
  t.Num("mapper.seed", &m.seed, 0, 1e18, "", "keyframe sampling and splitting seed");
  t.Str("mapper.device", &m.device, {},
        "where the map is optimised and rendered: cpu, cuda or cuda:N (needs a CUDA LibTorch build and a GPU)");

  // Masking.
  MaskingOptions& k = o->masking;
  t.Str("masking.segmenter.kind", &k.segmenter.kind, {"auto", "none", "yolox", "yolov8-seg", "png-folder"},
        "semantic segmenter");
  t.Str("masking.segmenter.model_path", &k.segmenter.model_path, {}, "ONNX detector (YOLOX or YOLOv8-seg)");
  t.Str("masking.segmenter.png_folder", &k.segmenter.png_folder, {}, "folder of <image>.png semantic masks");
  t.List("masking.segmenter.classes", &k.segmenter.classes, "COCO classes treated as dynamic (comma-separated)");
  t.Num("masking.segmenter.score_threshold", &k.segmenter.score_threshold, 0, 1, "", "min detection score");
  t.Num("masking.segmenter.nms_threshold", &k.segmenter.nms_threshold, 0, 1, "", "NMS IoU");
  t.Num("masking.segmenter.input_size", &k.segmenter.input_size, 0, 4096, "px", "network input (0 = model's)");
  t.Num("masking.segmenter.enclosing_score_ratio", &k.segmenter.enclosing_score_ratio, 0, 1, "",
        "YOLOX: a box holding a same-class box scoring 1/ratio times more is dropped (0 = off)");
  t.Num("masking.segmenter.second_look_max_cover", &k.segmenter.second_look_max_cover, 0, 1, "",
        "YOLOX: a box its depth region covers less of is searched again with the region greyed (0 = off)");
  t.Bool("masking.segmenter.rect_input", &k.segmenter.rect_input,
         "YOLOX: input_size on the image's long side, the other side just holds the image (square if false)");
  t.Num("masking.segmenter.mask_threshold", &k.segmenter.mask_threshold, 0, 1, "", "YOLOv8-seg mask threshold");
  t.Num("masking.segmenter.dilation_px", &k.segmenter.dilation_px, 0, 100, "px", "model masks grow by this");
  t.Bool("masking.segmenter.png_missing_is_empty", &k.segmenter.png_missing_is_empty, "missing PNG = empty mask");
  DepthBoxMaskOptions& bm = k.segmenter.box_mask;
  t.Bool("masking.segmenter.box_mask.whole_box", &bm.whole_box, "YOLOX: the whole box is the mask (no depth region)");
  t.Num("masking.segmenter.box_mask.whole_box_border_px", &bm.whole_box_border_px, -1, 10000, "px",
        "YOLOX: a box this close to the left or right border is the mask whole (-1 = never)");
  t.Num("masking.segmenter.box_mask.step_tolerance", &bm.step_tolerance, 0, inf, "m",
        "YOLOX depth region: largest depth step between neighbours");
  t.Num("masking.segmenter.box_mask.range_tolerance", &bm.range_tolerance, 1e-6, inf, "m",
        "YOLOX depth region: pixels within this distance of the object's depth");
  t.Num("masking.segmenter.box_mask.min_valid_fraction", &bm.min_valid_fraction, 0, 1, "",
        "YOLOX: fewer valid depths in the box's core: the whole box");
  t.Num("masking.segmenter.box_mask.min_box_iou", &bm.min_box_iou, 0, 1, "",
        "YOLOX: a farther depth mode is tried when the nearest one's region covers less of the box (a person behind a desk)");
  t.Num("masking.segmenter.box_mask.behind_min_height", &bm.behind_min_height, 0, 1, "",
        "YOLOX: a farther layer touching the region, this tall (fraction of the box) and not around it, joins (0 = off)");
  t.Num("masking.schedule.interval", &k.schedule.interval, 1, 1000, "frames", "detector every n frames");
  t.Num("masking.schedule.max_carry_frames", &k.schedule.max_carry_frames, 1, 1000, "frames",
        "detector results older than this are dropped");
  t.Bool("masking.use_flow", &k.use_flow, "flow-motion mask");
  t.Num("masking.flow.scale", &k.flow.scale, 1e-3, 1, "", "flow at this fraction of the image size");
  t.Num("masking.flow.dis_preset", &k.flow.dis_preset, 0, 2, "", "DIS preset: 0 ultrafast, 1 fast, 2 medium");
  t.Num("masking.flow.residual_threshold_px", &k.flow.residual_threshold_px, 1e-6, inf, "px", "flow residual");
  t.Num("masking.flow.noise_factor", &k.flow.noise_factor, 0, inf, "", "depth-noise sigmas added");
  t.Num("masking.flow.relative_threshold", &k.flow.relative_threshold, 0, inf, "",
        "plus this fraction of the rigid flow's length (errors that grow with the motion)");
  t.Num("masking.flow.depth_noise_abs", &k.flow.depth_noise_abs, 0, inf, "m", "depth noise sigma, constant");
  t.Num("masking.flow.depth_noise_rel", &k.flow.depth_noise_rel, 0, inf, "1/m", "depth noise sigma, quadratic");
  t.Num("masking.flow.max_depth", &k.flow.max_depth, 1e-6, inf, "m", "farther pixels are never moving");
  t.Num("masking.flow.occlusion_margin", &k.flow.occlusion_margin, 1e-6, inf, "m", "occlusion margin");
  t.Num("masking.flow.open_px", &k.flow.open_px, 0, 51, "px", "opening kernel");
  t.Num("masking.flow.close_px", &k.flow.close_px, 0, 51, "px", "closing kernel");
  t.Num("masking.flow.min_region_px", &k.flow.min_region_px, 0, inf, "px^2", "smaller regions dropped");
  t.Bool("masking.flow.estimate_pose", &k.flow.estimate_pose, "refine the relative pose on the flow");
  t.Num("masking.flow.pose_grid_px", &k.flow.pose_grid_px, 2, 64, "px", "pose sample spacing");
  t.Num("masking.flow.pose_inlier_px", &k.flow.pose_inlier_px, 1e-6, inf, "px", "PnP inlier threshold");
  t.Num("masking.flow.pose_min_inliers", &k.flow.pose_min_inliers, 6, inf, "", "min PnP inliers");
  t.Bool("masking.use_epipolar", &k.use_epipolar, "epipolar check of features");
  t.Num("masking.epipolar.max_features", &k.epipolar.max_features, 8, inf, "", "FAST corners when none given");
  t.Num("masking.epipolar.fast_threshold", &k.epipolar.fast_threshold, 1, 255, "", "FAST threshold");
  t.Num("masking.epipolar.grid_cell_px", &k.epipolar.grid_cell_px, 8, inf, "px", "corner spreading cells");
  t.Num("masking.epipolar.lk_window_px", &k.epipolar.lk_window_px, 5, 61, "px", "LK window (odd)");
  t.Num("masking.epipolar.lk_levels", &k.epipolar.lk_levels, 0, 6, "", "LK pyramid levels");
  t.Num("masking.epipolar.border_px", &k.epipolar.border_px, 0, inf, "px", "border margin");
  t.Num("masking.epipolar.patch_radius_px", &k.epipolar.patch_radius_px, 0, 7, "px", "patch radius");
  t.Num("masking.epipolar.max_patch_difference", &k.epipolar.max_patch_difference, 1e-6, inf, "", "patch check");
  t.Str("masking.epipolar.method", &k.epipolar.method, {"fast_ransac", "ransac", "lmeds", "magsac", "usac_fast", "usac_accurate"}, "robust fit of F");
  t.Num("masking.epipolar.ransac_threshold_px", &k.epipolar.ransac_threshold_px, 1e-6, inf, "px", "F inliers");
  t.Num("masking.epipolar.ransac_confidence", &k.epipolar.ransac_confidence, 1e-6, 0.999999, "", "confidence");
  t.Num("masking.epipolar.epipolar_threshold_px", &k.epipolar.epipolar_threshold_px, 1e-6, inf, "px",
        "farther from the epipolar line: dynamic");
  t.Num("masking.epipolar.min_fit_points", &k.epipolar.min_fit_points, 8, inf, "", "min matches outside the mask");
  t.Bool("masking.use_background", &k.use_background, "background-depth refinement of the mask");
  BackgroundOptions& b = k.background;
  t.Num("masking.background.prior_weight", &b.prior_weight, 1e-6, inf, "", "trust in the prior");
  t.Num("masking.background.observation_weight", &b.observation_weight, 1e-6, inf, "", "trust in the observation");
  t.Num("masking.background.tolerance_abs", &b.tolerance_abs, 1e-6, inf, "m", "depth agreement, constant");
  t.Num("masking.background.tolerance_rel", &b.tolerance_rel, 0, inf, "1/m", "depth agreement, quadratic");
  t.Num("masking.background.front_factor", &b.front_factor, 1, inf, "", "clearly in front factor");
  t.Num("masking.background.window_radius_px", &b.window_radius_px, 1, 15, "px", "neighbourhood half-size");
  t.Num("masking.background.alignment_px", &b.alignment_px, 0, 15, "px", "misregistration tolerance");
  t.Num("masking.background.min_support", &b.min_support, 1, 255, "frames", "support to clear a detection");
  t.Num("masking.background.min_valid_fraction", &b.min_valid_fraction, 1e-6, 1, "", "valid window fraction");
  t.Num("masking.background.static_fraction", &b.static_fraction, 1e-6, 1, "", "agreeing fraction for static");
  t.Num("masking.background.dynamic_fraction", &b.dynamic_fraction, 1e-6, 1, "", "in-front fraction for dynamic");
  t.Bool("masking.background.add_dynamic", &b.add_dynamic, "pixels in front of B become dynamic");
  t.Bool("masking.background.remove_static", &b.remove_static, "masked pixels agreeing with B become static");
  t.Num("masking.background.added_open_px", &b.added_open_px, 0, 51, "px", "opening of added pixels");
  t.Num("masking.background.min_region_px", &b.min_region_px, 0, inf, "px^2", "smaller added regions dropped");
  t.Num("masking.background.max_depth", &b.max_depth, 1e-6, inf, "m", "farther depths invalid");
  t.Bool("masking.use_shore", &k.use_shore, "mask water and sky");
  t.Num("masking.shore.erode_px", &k.shore.erode_px, 0, 101, "px", "first erosion");
  t.Num("masking.shore.dilate_px", &k.shore.dilate_px, 0, 101, "px", "dilation");
  t.Num("masking.shore.final_erode_px", &k.shore.final_erode_px, 0, 101, "px", "last erosion");
  t.Bool("masking.shore.water_hue_high", &k.shore.water_hue_high, "water/sky are the high-hue class");
  t.Num("masking.shore.scale", &k.shore.scale, 1e-3, 1, "", "processing scale");
  t.Num("masking.weight_ramp_px", &k.weight_ramp_px, 0, inf, "px", "static weight ramp from the mask");

  // Tracker.
  OrbTrackerOptions& r = o->tracker;
  OrbExtractorOptions& e = r.extractor;
  t.Num("tracker.extractor.num_features", &e.num_features, 1, inf, "", "ORB features per frame");
  t.Num("tracker.extractor.num_levels", &e.num_levels, 1, 16, "", "pyramid levels");
  t.Num("tracker.extractor.scale_factor", &e.scale_factor, 1.0001, 2, "", "scale between levels");
  t.Num("tracker.extractor.cell_size", &e.cell_size, 8, inf, "px", "grid cell edge");
  t.Num("tracker.extractor.initial_fast_threshold", &e.initial_fast_threshold, 1, 255, "", "FAST t_init");
  t.Num("tracker.extractor.fallback_fast_threshold", &e.fallback_fast_threshold, 1, 255, "", "FAST t_fallback");
  t.Num("tracker.extractor.min_corners_per_cell", &e.min_corners_per_cell, 1, inf, "", "corners per cell");
  t.Bool("tracker.extractor.adaptive_threshold", &e.adaptive_threshold, "adaptive mask-aware FAST thresholds");
  t.Num("tracker.extractor.adaptive_exponent", &e.adaptive_exponent, 0, 4, "", "relaxation control");
  t.Num("tracker.extractor.min_fast_threshold", &e.min_fast_threshold, 1, 255, "", "lowest relaxed threshold");
  t.Num("tracker.extractor.min_static_fraction", &e.min_static_fraction, 0, 0.999999, "", "cells below: no feature");
  t.Num("tracker.extractor.mask_dilation", &e.mask_dilation, 0, 50, "px", "mask growth before use");
  t.Bool("tracker.extractor.undistort", &e.undistort, "undistort keypoints");
  t.Bool("tracker.extractor.parallel_levels", &e.parallel_levels, "pyramid levels on OpenCV worker threads");
  PoseOptimizerOptions& p = r.optimizer;
  t.Num("tracker.optimizer.rounds", &p.rounds, 1, inf, "", "BA rounds");
  t.Num("tracker.optimizer.iterations_per_round", &p.iterations_per_round, 1, inf, "", "LM iterations per round");
  t.Num("tracker.optimizer.chi2_mono", &p.chi2_mono, 1e-9, inf, "", "inlier threshold, 2 DoF");
  t.Num("tracker.optimizer.chi2_depth", &p.chi2_depth, 1e-9, inf, "", "inlier threshold, 3 DoF");
  t.Bool("tracker.optimizer.huber", &p.huber, "Huber loss");
  t.Num("tracker.optimizer.virtual_baseline", &p.virtual_baseline, 1e-9, inf, "m", "virtual stereo baseline");
  t.Num("tracker.optimizer.disparity_sigma_scale", &p.disparity_sigma_scale, 1e-9, inf, "", "disparity sigma");
  t.Num("tracker.optimizer.min_inliers", &p.min_inliers, 3, inf, "", "min inliers per round");
  t.Num("tracker.min_depth", &r.min_depth, 1e-9, inf, "m", "nearer readings ignored");
  t.Num("tracker.max_depth", &r.max_depth, 1e-9, inf, "m", "farther readings ignored");
  t.Num("tracker.max_depth_spread", &r.max_depth_spread, 1e-9, inf, "", "depth edge spread");
  t.Num("tracker.close_depth", &r.close_depth, 1e-9, inf, "m", "keyframes create points nearer than this");
  t.Num("tracker.min_new_points", &r.min_new_points, 0, inf, "", "min new points per keyframe");
  t.Num("tracker.min_point_weight", &r.min_point_weight, 0, 1, "", "min static weight of new points");
  t.Num("tracker.min_init_features", &r.min_init_features, 10, inf, "", "features with depth to start");
  StereoFeatureOptions& st = r.stereo;
  t.Num("tracker.stereo.baseline", &st.baseline, 0, inf, "m",
        "sparse stereo depth of the features (set from the dataset's rig with sparse_stereo_tracking; 0 = off)");
  t.Num("tracker.stereo.min_disparity", &st.min_disparity, 1e-3, inf, "px", "smallest disparity");
  t.Num("tracker.stereo.max_disparity", &st.max_disparity, 1, inf, "px", "largest disparity");
  t.Num("tracker.stereo.row_band_px", &st.row_band_px, 0, 50, "px", "rows a right feature serves (x level scale)");
  t.Num("tracker.stereo.max_distance", &st.max_distance, 1, 256, "bits", "largest Hamming distance of a match");
  t.Num("tracker.stereo.ratio", &st.ratio, 1e-3, 1, "", "best / second-best distance limit");
  t.Num("tracker.stereo.window_px", &st.window_px, 3, 31, "px", "SAD patch (odd)");
  t.Num("tracker.stereo.search_px", &st.search_px, 1, 20, "px", "SAD search either side");
  t.Num("tracker.stereo.outlier_factor", &st.outlier_factor, 1, inf, "", "SAD above this x median is dropped");
  t.Num("tracker.stereo.prior_search_px", &st.prior_search_px, 1, 20, "px",
        "with a depth prior: SAD search beyond the prior's disparity range either side");
  t.Num("tracker.stereo.prior_max_range_px", &st.prior_max_range_px, 3, inf, "px",
        "with a depth prior: widest disparity range searched (wider: no depth)");
  t.Num("tracker.restart_after_lost", &r.restart_after_lost, 0, inf, "frames",
        "after this many frames lost in a row a new map starts at the predicted pose (0 = never)");
  t.Num("tracker.local_keyframes", &r.local_keyframes, 1, inf, "", "covisible keyframes in the local map");
  t.Num("tracker.recent_keyframes", &r.recent_keyframes, 0, inf, "", "newest keyframes in the local map");
  t.Num("tracker.coarse_radius", &r.coarse_radius, 1e-9, inf, "px", "coarse search window");
  t.Num("tracker.wide_radius", &r.wide_radius, 1e-9, inf, "px", "wide retry window");
  t.Num("tracker.fine_radius", &r.fine_radius, 1e-9, inf, "px", "fine search window");
  t.Num("tracker.max_projection_distance", &r.max_projection_distance, 1, 256, "bits", "Hamming limit");
  t.Num("tracker.max_keyframe_distance", &r.max_keyframe_distance, 1, 256, "bits", "Hamming limit");
  t.Num("tracker.match_ratio", &r.match_ratio, 1e-9, 1, "", "ratio test (projection)");
  t.Num("tracker.keyframe_match_ratio", &r.keyframe_match_ratio, 1e-9, 1, "", "ratio test (keyframes)");
  t.Num("tracker.min_coarse_inliers", &r.min_coarse_inliers, 6, inf, "", "coarse stage inliers");
  t.Num("tracker.last_frame_points", &r.last_frame_points, 0, inf, "",
        "coarse stage: temporary points from the last frame's unmatched features with depth, nearest first (0 = none)");
  t.Num("tracker.min_inliers", &r.min_inliers, 6, inf, "", "inliers to track a frame");
  t.Num("tracker.relocalisation_min_inliers", &r.relocalisation_min_inliers, 6, inf, "", "relocalisation inliers");
  t.Num("tracker.relocalisation_candidates", &r.relocalisation_candidates, 1, inf, "", "keyframes tried");
  t.Num("tracker.keyframe_max_frames", &r.keyframe_max_frames, 1, inf, "frames", "tracker keyframe period");
  t.Num("tracker.keyframe_tracked_ratio", &r.keyframe_tracked_ratio, 0, 1, "", "tracker keyframe ratio");
  t.Num("tracker.keyframe_min_coverage", &r.keyframe_min_coverage, 0, 1, "", "tracker keyframe coverage");
  t.Num("tracker.cull_min_found_ratio", &r.cull_min_found_ratio, 0, 1, "", "map point culling ratio");
  t.Num("tracker.cull_min_visible", &r.cull_min_visible, 1, inf, "", "culling after this many sightings");
  t.Bool("tracker.relocalisation_bow", &r.relocalisation_bow, "relocalisation candidates by bag of words");
  t.Bool("tracker.relocalisation_thumbnails", &r.relocalisation_thumbnails, "... and by thumbnail");
  t.Str("tracker.vocabulary_path", &r.vocabulary_path, {}, "vocabulary file (dypho vocab train); empty = trained at start-up");
  t.Num("tracker.vocabulary_train_keyframes", &r.vocabulary_train_keyframes, 1, inf, "", "start-up vocabulary from keyframes");
  t.Num("tracker.vocabulary.branching", &r.vocabulary.branching, 2, 1000, "", "start-up vocabulary branching");
  t.Num("tracker.vocabulary.levels", &r.vocabulary.levels, 1, 10, "", "start-up vocabulary levels");
  LocalBaOptions& ba = r.local_ba;
  t.Bool("tracker.local_ba.enabled", &ba.enabled, "local BA after every keyframe (--disable local-ba)");
  t.Num("tracker.local_ba.fixed_lag", &ba.fixed_lag, 0, 1000, "frames",
        "threaded: a local BA is applied this many frames after its keyframe (0 = when ready, timing-dependent)");
  t.Num("tracker.local_ba.max_keyframes", &ba.max_keyframes, 1, inf, "", "covisible keyframes optimised");
  t.Num("tracker.local_ba.min_shared", &ba.min_shared, 1, inf, "", "shared points for covisibility");
  t.Num("tracker.local_ba.max_fixed_keyframes", &ba.max_fixed_keyframes, 1, inf, "", "fixed keyframes");
  t.Num("tracker.local_ba.first_iterations", &ba.first_iterations, 1, inf, "", "LM iterations before outliers go");
  t.Num("tracker.local_ba.iterations", &ba.iterations, 0, inf, "", "LM iterations after that");
  t.Bool("tracker.local_ba.cull_keyframes", &ba.cull_keyframes, "cull redundant keyframes after local BA");
  t.Str("tracker.local_ba.solver", &ba.solver, {"ceres", "eigen"},
        "local and global BA solver: ceres (Ceres, DENSE_SCHUR) or eigen (our sparse LM); the same cost");
  t.Num("tracker.local_ba.disparity_sigma_scale", &ba.disparity_sigma_scale, 0, inf, "",
        "BA depth residual sigma scale (0 = tracker.optimizer's)");
  KeyframeCullingOptions& kc = r.keyframe_culling;
  t.Num("tracker.keyframe_culling.redundant_ratio", &kc.redundant_ratio, 1e-9, 1, "", "points seen elsewhere");
  t.Num("tracker.keyframe_culling.min_observers", &kc.min_observers, 1, inf, "", "other keyframes per point");
  t.Num("tracker.keyframe_culling.keep_newest", &kc.keep_newest, 1, inf, "", "newest keyframes kept");
  LoopClosingOptions& lc = r.loops;
  t.Bool("tracker.loops.enabled", &lc.enabled, "loop detection and closure (--disable loops)");
  t.Num("tracker.loops.fixed_lag", &lc.fixed_lag, 0, 1000, "frames",
        "threaded runs: a loop closure applied this many frames after its keyframe (0 = when ready)");
  t.Num("tracker.loops.min_keyframes", &lc.min_keyframes, 2, inf, "", "keyframes before loops are searched");
  t.Num("tracker.loops.covisible_min_shared", &lc.covisible_min_shared, 1, inf, "", "shared points of neighbours");
  t.Num("tracker.loops.min_score_ratio", &lc.min_score_ratio, 0, inf, "", "candidate score / weakest neighbour's");
  t.Num("tracker.loops.min_score", &lc.min_score, 0, 1, "", "lowest candidate BoW score");
  t.Num("tracker.loops.max_candidates", &lc.max_candidates, 1, inf, "", "BoW results per query");
  t.Num("tracker.loops.min_consistent", &lc.min_consistent, 0, inf, "", "consecutive consistent keyframes");
  t.Num("tracker.loops.strong_covisibility", &lc.strong_covisibility, 1, inf, "", "essential-graph covisibility");
  t.Num("tracker.loops.min_inliers", &lc.verification.min_inliers, 3, inf, "", "3D-3D inliers to accept");
  t.Num("tracker.loops.inlier_distance", &lc.verification.inlier_distance, 1e-9, inf, "m", "3D-3D inlier distance");
  t.Num("tracker.loops.ransac_iterations", &lc.verification.ransac_iterations, 1, inf, "", "RANSAC samples");
  t.Num("tracker.loops.graph_iterations", &lc.pose_graph.iterations, 1, inf, "", "pose-graph LM iterations");

  // The built-in synthetic sequence.
  SynthOptions& s = o->synth;
  t.Num("synth.width", &s.width, 16, 8192, "px", "image width");
  t.Num("synth.height", &s.height, 16, 8192, "px", "image height");
  t.Num("synth.frames", &s.frames, 1, 1000000, "frames", "number of frames");
  t.Num("synth.fps", &s.fps, 1e-3, 1000, "Hz", "frame rate");
  t.Num("synth.seed", &s.seed, 0, 1e18, "", "textures, walkers, noise");
  t.Str("synth.scene", &o->synth_scene, {"room", "shore"}, "room (indoor, walkers) or shore (harbour from a boat)");
  t.Str("synth.motion", &o->synth_motion, {"xyz", "rpy", "halfsphere", "static", "loop"}, "camera motion (room)");
  t.Num("synth.num_walkers", &s.num_walkers, 0, 4, "", "walkers (shore: pedestrians)");
  t.Num("synth.walker_speed", &s.walker_speed, 0.2, 3, "m/s", "walker speed");
  t.Num("synth.max_coverage", &s.max_coverage, 1e-6, 1, "", "max image fraction covered by walkers");
  t.Bool("synth.depth_noise", &s.depth_noise, "Kinect-like depth noise");
  return t.rows;
}

}  // namespace dypho
