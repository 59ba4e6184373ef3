# Panoramic Hough Transform: whole-image PH against cv::HoughLines on the same
# edge image, tracking mode per edge, GPU batch when a device is present.
pano_add_benchmark(hough pano_hough pano_pose opencv_core opencv_imgproc OpenMP::OpenMP_CXX)
