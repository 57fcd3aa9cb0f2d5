// `dypho vocab train FOLDERS... --out vocab.bin`: trains a bag-of-words
// vocabulary (tracker/backend/vocabulary.h) on the ORB descriptors of
// dataset frames, for the tracker's place recognition
// (tracker.vocabulary_path).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "tools/cli_checks.h"
#include "tools/command.h"
#include "tracker/backend/vocabulary.h"
#include "tracker/cv_view.h"
#include "tracker/orb_extractor.h"
#include "tracker/orb_matcher.h"

namespace dypho::tools {
namespace {

int RunVocab(int argc, char** argv) {
  CLI::App app{
      "Train a bag-of-binary-words vocabulary (k-majority tree, tf-idf) on the ORB descriptors of the frames of "
      "one or more RGB-D datasets (TUM/Bonn layout or a generic folder with camera.yaml); every --every-th "
      "frame is one training image. `dypho track --vocabulary FILE` and `dypho run --set "
      "tracker.vocabulary_path=FILE` use it.",
      "dypho vocab"};
  app.require_subcommand(1);
  CLI::App* train = app.add_subcommand("train", "train a vocabulary");
  std::vector<std::string> folders;
  std::string out;
  int every = 5;
  int features = 1000;
  VocabularyOptions options;
  train->add_option("folders", folders, "dataset folders")->required();
  train->add_option("--out", out, "vocabulary file to write")->required()->check(NonEmptyPath());
  train->add_option("--every", every, "use every N-th frame")->capture_default_str()->check(CLI::PositiveNumber);
  train->add_option("--features", features, "ORB features per frame")->capture_default_str()->check(CLI::PositiveNumber);
  train->add_option("--branching", options.branching, "children per node (k)")->capture_default_str();
  train->add_option("--levels", options.levels, "tree depth (words <= k^levels)")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  std::vector<std::vector<Descriptor>> images;
  size_t total = 0;
  for (const std::string& folder : folders) {
    const std::unique_ptr<Dataset> dataset = OpenDataset(folder);
    OrbExtractorOptions orb;
    orb.num_features = features;
    OrbExtractor extractor(orb, dataset->camera());
    size_t used = 0;
    for (size_t i = 0; i < dataset->size(); i += every) {
      const Frame frame = dataset->Load(i);
      cv::Mat gray;
      cv::cvtColor(CvView(frame.rgb), gray, cv::COLOR_RGB2GRAY);
      const OrbFeatures f = extractor.Extract(gray, cv::Mat(), cv::Mat());
      if (f.size() == 0) continue;
      images.push_back(DescriptorsFromMat(f.descriptors));
      total += images.back().size();
      ++used;
    }
    std::printf("%s: %zu frames\n", folder.c_str(), used);
  }
  DYPHO_CHECK_INPUT(total > 0) << "no ORB features in the frames of " << folders.front()
                               << (folders.size() > 1 ? " and the other folders" : "");
  const Vocabulary vocabulary = Vocabulary::Train(images, options);
  vocabulary.Save(out);
  std::printf("vocabulary %s: %d words (branching %d, %d levels) from %zu descriptors of %zu images\n", out.c_str(),
              vocabulary.num_words(), options.branching, options.levels, total, images.size());
  return 0;
}

}  // namespace

DYPHO_COMMAND("vocab", "train a bag-of-words vocabulary for place recognition (vocab train FOLDERS... --out FILE)",
              RunVocab);

}  // namespace dypho::tools
