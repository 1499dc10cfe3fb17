//! A track run's folder read back (`brachia track`): the report, the closed-loop log, the plant's
//! world and the plan it tracked, each file checked by the readers of [`crate::read`].

use crate::read::{
    inside, inside_dir, need, past_schema_line, read_contacts, read_csv_text, read_json,
    read_obstacle_track, PlanFolder,
};
use crate::track_run::{PlantWorld, TrackReport};
use brachia::sim::ClosedLoopLog;
use brachia::Error;
use std::path::{Path, PathBuf};

/// A track run's folder read back (`brachia track`).
#[derive(Debug, Clone)]
pub struct TrackFolder {
    /// The folder.
    pub dir: PathBuf,
    /// `report.json`.
    pub report: TrackReport,
    /// `closed_loop.csv`, with the plant and controller names of the report (no controller timings).
    pub log: ClosedLoopLog,
    /// The plant's world: the report's obstacles, `contacts.csv` and `obstacles.csv` (empty when absent,
    /// as on the model plant).
    pub world: PlantWorld,
    /// The plan under `plan/`, when this run planned it.
    pub plan: Option<PlanFolder>,
}

const TRACK_FOLDER: &str =
    "a track folder written by `brachia track` (report.json, closed_loop.csv)";

impl TrackFolder {
    /// Read the track folder `dir`: `report.json`, `closed_loop.csv` ([`ClosedLoopLog::from_csv`]),
    /// `contacts.csv` and `obstacles.csv` when present, and the plan folder `plan/` when present.
    pub fn read(dir: &Path) -> Result<Self, Error> {
        let rfile = need(dir, "report.json", TRACK_FOLDER)?;
        let lfile = need(dir, "closed_loop.csv", TRACK_FOLDER)?;
        let report: TrackReport = read_json(&rfile, crate::schema::JsonKind::TrackReport)?;
        let text = read_csv_text(&lfile, "closed_loop")?;
        let mut log = ClosedLoopLog::from_csv(&text, &lfile.display().to_string())
            .map_err(past_schema_line)?;
        log.controller = report.controller.clone();
        log.plant = report.plant.clone();
        let mut world = PlantWorld {
            obstacles: report.plant_obstacles.clone(),
            ..PlantWorld::default()
        };
        if let Some(cfile) = inside(dir, "contacts.csv")? {
            world.contacts = read_contacts(&cfile, log.n, world.obstacles.len())?;
        }
        if let Some(ofile) = inside(dir, "obstacles.csv")? {
            world.track = read_obstacle_track(&ofile, &world.obstacles)?;
        }
        let plan = match inside_dir(dir, "plan")? {
            Some(p) => Some(PlanFolder::read(&p)?),
            None => None,
        };
        Ok(TrackFolder {
            dir: dir.to_path_buf(),
            report,
            log,
            world,
            plan,
        })
    }
}
