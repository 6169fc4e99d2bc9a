//! Sculpt files on disk: `Sculpt::save` (atomic: a temporary file in the target's directory
//! renamed into place) and `Sculpt::open` (regular files only, size checked before reading),
//! with errors naming the path.

use std::path::Path;

use glam::{DVec3, IVec3};
use volga_sculpt::{FileError, Operation, Sculpt, SculptFileError, SculptGrid, Stroke, Tool};
use volga_shapes::{AxisBox, FilteredDensity, OrientedBoxFilter};

fn sculpt() -> Sculpt {
    let grid = SculptGrid::new(DVec3::new(1.0, -2.0, 0.5), 0.25, 2).unwrap();
    let block = FilteredDensity::new(
        AxisBox::new(grid.voxel_center(IVec3::splat(5)), grid.voxel_center(IVec3::splat(27))).unwrap(),
        OrientedBoxFilter::for_spacing(DVec3::splat(0.25)),
    );
    let mut s = Sculpt::from_field(grid, &block, [0.8, 0.7, 0.6]);
    s.apply(
        &Stroke::new(
            Tool::sphere(grid.voxel_center(IVec3::new(16, 16, 5)), 2.5).unwrap(),
            Operation::Carve,
        )
        .unwrap(),
    );
    s.apply(
        &Stroke::new(
            Tool::sphere(grid.voxel_center(IVec3::new(10, 20, 16)), 2.0).unwrap(),
            Operation::Paint {
                colour: [0.1, 0.9, 0.2],
                strength: 0.7,
            },
        )
        .unwrap(),
    );
    s
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn names_path(e: &SculptFileError, path: &Path) {
    assert_eq!(e.path(), path);
    assert!(e.to_string().contains(&path.display().to_string()), "{e}");
}

#[test]
fn save_then_open_round_trips_and_overwrites_in_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.vsculpt");
    let s = sculpt();
    s.save(&path).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), s.to_bytes());
    assert_eq!(s.file_len(), s.to_bytes().len() as u64);
    assert_eq!(
        Sculpt::empty(*s.grid(), [0.0; 3]).file_len(),
        Sculpt::empty(*s.grid(), [0.0; 3]).to_bytes().len() as u64
    );
    let back = Sculpt::open(&path).unwrap();
    assert!(back.same_tree(&s));
    // Saving again over the file replaces it, and leaves no temporary file.
    let mut t = s.clone();
    t.apply(
        &Stroke::new(
            Tool::sphere(t.grid().voxel_center(IVec3::splat(16)), 3.0).unwrap(),
            Operation::Carve,
        )
        .unwrap(),
    );
    t.save(&path).unwrap();
    assert!(Sculpt::open(&path).unwrap().same_tree(&t));
    assert_eq!(listing(dir.path()), ["a.vsculpt"]);
    // A file of exactly the limit opens; one byte less refuses it before reading.
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(Sculpt::open_with_limit(&path, size).is_ok());
    let e = Sculpt::open_with_limit(&path, size - 1).unwrap_err();
    assert!(
        matches!(e, SculptFileError::TooLarge { size: s, limit, .. } if s == size && limit == size - 1),
        "{e:?}"
    );
    names_path(&e, &path);
}

#[cfg(unix)]
#[test]
fn saved_files_get_the_permissions_of_a_new_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let (plain, saved) = (dir.path().join("plain"), dir.path().join("s.vsculpt"));
    std::fs::write(&plain, b"x").unwrap();
    sculpt().save(&saved).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(
        mode(&saved),
        mode(&plain),
        "as std::fs::write would create it (umask applied)"
    );
}

#[test]
fn saving_into_a_missing_directory_fails_naming_the_path_and_creates_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing").join("a.vsculpt");
    let e = sculpt().save(&path).unwrap_err();
    assert!(
        matches!(&e, SculptFileError::Write { source, .. } if source.kind() == std::io::ErrorKind::NotFound),
        "{e:?}"
    );
    names_path(&e, &path);
    // The message names the target only, not the temporary file.
    assert!(
        !e.to_string().contains(".a.vsculpt.") && !e.to_string().contains("at path"),
        "{e}"
    );
    assert!(
        e.to_string()
            .ends_with("a.vsculpt: No such file or directory (os error 2)")
            || !cfg!(target_os = "linux"),
        "{e}"
    );
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn saving_over_a_directory_fails_naming_the_path_and_leaves_it_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.vsculpt");
    std::fs::create_dir(&path).unwrap();
    std::fs::write(path.join("inside"), b"kept").unwrap();
    let e = sculpt().save(&path).unwrap_err();
    assert!(matches!(e, SculptFileError::Write { .. }), "{e:?}");
    names_path(&e, &path);
    assert!(path.is_dir());
    assert_eq!(listing(&path), ["inside"]);
    assert_eq!(listing(dir.path()), ["a.vsculpt"], "no temporary file left beside it");
}

#[test]
fn a_failed_save_leaves_the_existing_file_intact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.vsculpt");
    let s = sculpt();
    s.save(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    // A path whose file name is missing ("a.vsculpt/..") cannot be written; the file stays.
    assert!(sculpt().save(path.join("..")).is_err());
    // Nor can a file inside a file.
    let e = s.save(path.join("b.vsculpt")).unwrap_err();
    names_path(&e, &path.join("b.vsculpt"));
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(listing(dir.path()), ["a.vsculpt"]);
    // (A write failing half-way is tested inside the crate, by injecting the failure.)
}

#[test]
fn open_refuses_what_is_not_a_sculpt_file_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.vsculpt");
    let e = Sculpt::open(&missing).unwrap_err();
    assert!(
        matches!(&e, SculptFileError::Read { source, .. } if source.kind() == std::io::ErrorKind::NotFound),
        "{e:?}"
    );
    names_path(&e, &missing);

    let e = Sculpt::open(dir.path()).unwrap_err();
    assert!(matches!(e, SculptFileError::NotAFile { .. }), "{e:?}");
    names_path(&e, dir.path());
    assert!(e.to_string().ends_with(": not a regular file"), "{e}");

    #[cfg(unix)]
    {
        // A device is refused without reading it (reading /dev/zero would never end).
        let e = Sculpt::open("/dev/zero").unwrap_err();
        assert!(matches!(e, SculptFileError::NotAFile { .. }), "{e:?}");
    }

    let damaged = dir.path().join("damaged.vsculpt");
    let mut bytes = sculpt().to_bytes();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&damaged, &bytes).unwrap();
    let e = Sculpt::open(&damaged).unwrap_err();
    assert!(
        matches!(
            e,
            SculptFileError::Format {
                source: FileError::Checksum { .. },
                ..
            }
        ),
        "{e:?}"
    );
    names_path(&e, &damaged);
    assert!(e.to_string().contains("checksum"), "{e}");

    let empty = dir.path().join("empty.vsculpt");
    std::fs::write(&empty, b"").unwrap();
    let e = Sculpt::open(&empty).unwrap_err();
    assert!(
        matches!(
            e,
            SculptFileError::Format {
                source: FileError::Truncated { len: 0, .. },
                ..
            }
        ),
        "{e:?}"
    );
}
